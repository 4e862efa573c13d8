#!/usr/bin/env bash
# The robot's own localisation (`uncertainty.localization: reported`, docs/execution.md)
# against the default (`at_stops`), at one commit. Run from the repository's main checkout
# once the motion studies are done:  bash docs/studies/localisation_study.sh COMMIT
# It makes the worktree ../localisation-COMMIT at COMMIT, restores the rows already committed
# under docs/studies/localisation_COMMIT/ into its out/ folders, and resumes: `s3o evaluate`
# skips the runs that have a row. Every hour it copies the rows back and commits them as
# `data:`. The default's rows are the motion study's (smooth, S3O-GROP*, docs/studies/
# motion_COMMIT.tar.xz): where COMMIT is another commit, `same_runs` checks on the dense
# room's first 20 tasks that COMMIT repeats them.
set -euo pipefail
main="$(git rev-parse --show-toplevel)"
commit="${1:?usage: localisation_study.sh COMMIT}"
here="$main/docs/studies/localisation_$commit"
studies=(same_runs dense_open_loop spacious_open_loop dense_recovery spacious_recovery
         two_process)
# shellcheck source=docs/studies/rows.sh
. "$main/docs/studies/rows.sh"
enter_study "$main" "$here" "$main/../localisation-$commit" "$commit" "${studies[@]}"
for name in "${studies[@]:0:5}"; do
    room=${name%%_*}; [ "$room" = same ] && room=dense
    [ -f "out/$name/difficulty.jsonl" ] ||
        tar -xJOf "$main/docs/studies/${room}_open_loop_494b2e6.tar.xz" \
            "${room}_open_loop/difficulty.jsonl" > "out/$name/difficulty.jsonl"
done
keep_rows_hourly "$main" "$here" "the localisation study at $commit" "${studies[@]}"
REPORTED="--set uncertainty.localization=reported"
# Exit status 1: some run ended in an error, which its row records; go on.
ev() { s3o evaluate --quiet --workers 2 "$@" || [ $? -eq 1 ]; }
# Does COMMIT repeat the motion study's default runs?
ev --tasks scenarios/generated_dense --count 20 --methods "S3O-GROP*" --seeds 1 \
    --out out/same_runs
for room in dense spacious; do
    tasks=scenarios/generated_dense; [ "$room" = spacious ] && tasks=scenarios/generated
    ev --tasks $tasks --methods "S3O-GROP*" --seeds 3 $REPORTED --out out/${room}_open_loop
done
for room in dense spacious; do
    tasks=scenarios/generated_dense; [ "$room" = spacious ] && tasks=scenarios/generated
    ev --tasks $tasks --methods "S3O-GROP*" --seeds 3 $REPORTED --recovery replan \
        --open-loop out/${room}_open_loop --out out/${room}_recovery
done
# One process against two, the robot localising on its side (issue's agreement test).
s3o bench two-process $REPORTED --json out/two_process/results.jsonl \
    > out/two_process/summary.txt || true
echo "the localisation study at $commit: done"
