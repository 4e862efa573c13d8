"""The commands' Meshcat listens on localhost unless --host says otherwise."""

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
