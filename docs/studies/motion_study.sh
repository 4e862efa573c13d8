#!/usr/bin/env bash
# The smooth motion's studies at one commit (docs/results.md, "The smooth motion's studies").
# Run from the repository's main checkout:  bash docs/studies/motion_study.sh COMMIT
# It makes the worktree ../study64-COMMIT at COMMIT, restores the rows already kept, in
# docs/studies/motion_COMMIT/ while the study runs or in docs/studies/motion_COMMIT.tar.xz
# once it has shipped, into its out/ folders, and resumes: `s3o evaluate` skips the runs that
# have a row. Every hour it copies the rows back and commits them as `data:`.
set -euo pipefail
main="$(git rev-parse --show-toplevel)"
commit="${1:?usage: motion_study.sh COMMIT}"
here="$main/docs/studies/motion_$commit"
difficulty() { case "$1" in dense_*) echo dense ;; *) echo spacious ;; esac; }
studies=(same_runs_028cb79 same_runs_stop_and_go time_noise_off_dense time_noise_off_spacious
         dense_open_loop dense_open_loop_stop_and_go spacious_open_loop spacious_open_loop_stop_and_go
         dense_recovery spacious_recovery dense_recovery_stop_and_go spacious_recovery_stop_and_go)
# shellcheck source=docs/studies/rows.sh
. "$main/docs/studies/rows.sh"
enter_study "$main" "$here" "$main/../study64-$commit" "$commit" "${studies[@]}"
# A shipped study: its rows, one folder per cell, from the archive.
[ ! -f "$here.tar.xz" ] || tar -xJf "$here.tar.xz" -C out --strip-components=1 --skip-old-files
for name in "${studies[@]}"; do
    # 028cb79's own rows, the paper's motion before the smooth one existed.
    [ "$name" != same_runs_028cb79 ] || [ -f "out/$name/results.jsonl" ] ||
        tar -xJOf "$main/docs/studies/motion_ce2f701.tar.xz" \
            motion_ce2f701/same_runs_028cb79/results.jsonl > "out/$name/results.jsonl"
    case "$name" in same_runs_*|time_*) ;; *)
        [ -f "out/$name/difficulty.jsonl" ] ||
            tar -xJOf "$main/docs/studies/$(difficulty "$name")_open_loop_494b2e6.tar.xz" \
                "$(difficulty "$name")_open_loop/difficulty.jsonl" > "out/$name/difficulty.jsonl" ;;
    esac
done
# Hourly: the rows back into the main checkout (028cb79's own are not this study's).
keep_rows_hourly "$main" "$here" "the motion studies at $commit" "${studies[@]:1}"
SG="--set execution.motion=stop_and_go"
# Exit status 1: some run ended in an error, which its row records; go on.
ev() { s3o evaluate --quiet --workers 2 "$@" || [ $? -eq 1 ]; }
# same_runs_028cb79 holds 028cb79's rows made on an AMD EPYC with AVX-512: the runs depend on
# the processor (docs/results.md), so on another kind the comparison says nothing.
[ -s out/same_runs_028cb79/results.jsonl ] || echo "out/same_runs_028cb79: the 40 rows of 028cb79 are missing" >&2
# The dense room's first 20 tasks in both motions first, so that paired rows come early.
ev --tasks scenarios/generated_dense --count 20 --methods "S3O-GROP*" --seeds 3 --out out/dense_open_loop
ev --tasks scenarios/generated_dense --count 20 --methods "S3O-GROP*" --seeds 3 $SG --out out/dense_open_loop_stop_and_go
ev --tasks scenarios/generated --count 20 --methods "S3O-GROP*" V-GROP* --seeds 1 $SG --out out/same_runs_stop_and_go
s3o bench same-runs out/same_runs_028cb79 out/same_runs_stop_and_go > out/same_runs.txt || true
# The time model without noise: the plan's prediction against the simulation, smooth, on
# the first 20 tasks of each room (`s3o bench time`, its rows as it goes; it resumes).
for room in dense spacious; do
    tasks=scenarios/generated_dense; [ "$room" = spacious ] && tasks=scenarios/generated
    s3o bench time --tasks $tasks --count 20 --noise off --workers 2 \
        --json out/time_noise_off_$room/results.jsonl > out/time_noise_off_$room/summary.txt
done
# S3O-GROP* in both motions, open loop and with recovery, in both rooms: what the issue's
# 25 % is measured on. Then the Voronoi methods, smooth, for the claims table.
for room in dense spacious; do
    tasks=scenarios/generated_dense; [ "$room" = spacious ] && tasks=scenarios/generated
    ev --tasks $tasks --methods "S3O-GROP*" --seeds 3 --out out/${room}_open_loop
    ev --tasks $tasks --methods "S3O-GROP*" --seeds 3 $SG --out out/${room}_open_loop_stop_and_go
done
for room in dense spacious; do
    tasks=scenarios/generated_dense; [ "$room" = spacious ] && tasks=scenarios/generated
    ev --tasks $tasks --methods "S3O-GROP*" --seeds 3 --recovery replan \
        --open-loop out/${room}_open_loop --out out/${room}_recovery
    ev --tasks $tasks --methods "S3O-GROP*" --seeds 3 $SG --recovery replan \
        --open-loop out/${room}_open_loop_stop_and_go --out out/${room}_recovery_stop_and_go
done
for room in dense spacious; do
    tasks=scenarios/generated_dense; [ "$room" = spacious ] && tasks=scenarios/generated
    ev --tasks $tasks --methods "S3O-GROP*" V-GROP* V-GROP --seeds 3 --out out/${room}_open_loop
done
for room in dense spacious; do
    tasks=scenarios/generated_dense; [ "$room" = spacious ] && tasks=scenarios/generated
    ev --tasks $tasks --methods "S3O-GROP*" V-GROP* V-GROP --seeds 3 \
        --recovery replan --open-loop out/${room}_open_loop --out out/${room}_recovery
done
echo "the motion studies at $commit: done"
