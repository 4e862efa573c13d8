#!/usr/bin/env bash
# A new robot's measured terms once its build is done (docs/robots.md, "Adding a robot,
# step by step", 6): 20 tasks x 3 seeds per room, S3O-GROP*, open loop (Fea^m against the
# executed pickups, `s3o calibrate`; the predicted time against the simulated one; the
# shared stop's shares, `s3o shared-stop`) and with recovery (`s3o failure-price`), each
# planned with the paper's rating of what the robot has not measured yet.
# Run from the repository's main checkout:  bash docs/studies/robot_calibration.sh NAME COMMIT
# It makes the worktree ../calibration-NAME-COMMIT at COMMIT, restores the rows committed
# under docs/studies/calibration_NAME_COMMIT/, resumes, and commits the rows hourly (`data:`).
set -euo pipefail
main="$(git rev-parse --show-toplevel)"
name="${1:?usage: robot_calibration.sh NAME COMMIT}"
commit="${2:?usage: robot_calibration.sh NAME COMMIT}"
here="$main/docs/studies/calibration_${name}_$commit"
studies=(spacious_open_loop dense_open_loop spacious_recovery dense_recovery)
# shellcheck source=docs/studies/rows.sh
. "$main/docs/studies/rows.sh"
enter_study "$main" "$here" "$main/../calibration-$name-$commit" "$commit" "${studies[@]}"
keep_rows_hourly "$main" "$here" "$name's calibration at $commit" "${studies[@]}"
# Exit status 1: some run ended in an error, which its row records; go on.
ev() { s3o evaluate --quiet --workers 2 --methods "S3O-GROP*" --count 20 --seeds 3 \
           --set robot.name="$name" "$@" || [ $? -eq 1 ]; }
for room in spacious dense; do
    tasks=scenarios/generated; [ "$room" = dense ] && tasks=scenarios/generated_dense
    ev --tasks $tasks --set planner.shared_stop=paper --out out/${room}_open_loop
done
for room in spacious dense; do
    tasks=scenarios/generated; [ "$room" = dense ] && tasks=scenarios/generated_dense
    ev --tasks $tasks --set planner.failure_price=paper --recovery replan \
        --open-loop out/${room}_open_loop --out out/${room}_recovery
done
s3o calibrate out/spacious_open_loop out/dense_open_loop > out/calibration.txt || true
s3o shared-stop out/spacious_open_loop out/dense_open_loop --out out/shared_stop.yaml
s3o failure-price out/spacious_recovery out/dense_recovery --out out/failure_price.yaml
echo "$name's calibration at $commit: done; out/shared_stop.yaml and out/failure_price.yaml go to models/$name/"
