"""The commands' Meshcat listens on localhost unless --host says otherwise."""

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from s3o_drake.commands.common import MESHCAT_HOST, start_meshcat


def _listening_addresses(port: int) -> set[str]:
    """Local addresses (hex, as /proc/net/tcp writes them) of the sockets listening on
    `port`."""
    addresses = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        if not Path(table).is_file():
            continue
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            address, hex_port = fields[1].split(":")
            if int(hex_port, 16) == port and fields[3] == "0A":  # 0A: LISTEN
                addresses.add(address)
    return addresses


def test_run_s_meshcat_listens_on_localhost_only():
    assert MESHCAT_HOST == "localhost"
    meshcat = start_meshcat()  # as run makes it without --host
    url = meshcat.web_url()
    assert url.startswith(("http://localhost:", "http://127.0.0.1:"))
    addresses = _listening_addresses(meshcat.port())
    if not addresses:
        pytest.skip("no /proc/net/tcp to read the bound address from")
    # 0100007F is 127.0.0.1; all zeros would be every interface.
    assert not any(set(a) == {"0"} for a in addresses), addresses


def test_an_address_it_cannot_listen_on_is_one_line_and_status_2(capsys):
    with pytest.raises(SystemExit) as info:
        start_meshcat("192.0.2.1")  # TEST-NET-1: an address of no interface here
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --host: ") and err.count("\n") == 1


def test_every_run_of_a_process_gets_its_one_server_empty():
    from pydrake.geometry import Rgba, Sphere

    first = start_meshcat()
    first.SetObject("earlier_run", Sphere(0.1), Rgba(1, 0, 0, 1))  # where runs draw: /drake
    assert first.HasPath("earlier_run")
    again = start_meshcat()
    assert again is first
    assert not again.HasPath("earlier_run")


def test_a_server_held_in_a_finished_runs_cycles_survives_a_gc_on_another_thread():
    """Drake aborts when a Meshcat is destroyed on another thread than its maker's; the
    garbage collector may free a finished run's cycles on any thread (clingo's search runs
    Python on its own). In a child process: an abort would end it with SIGABRT."""
    child = textwrap.dedent("""
        import gc, threading
        from s3o_drake.commands.common import start_meshcat

        class Run:  # a finished run's diagram: it holds the server in a cycle
            pass
        run = Run()
        run.meshcat, run.itself = start_meshcat(), run
        del run
        collector = threading.Thread(target=gc.collect)
        collector.start()
        collector.join()
        print("alive")
        """)
    done = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr[-500:]
    assert done.stdout.strip() == "alive"
