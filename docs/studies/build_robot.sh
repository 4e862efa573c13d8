#!/usr/bin/env bash
# A robot's build (`s3o build robot NAME`) across sessions that end without warning.
# Run from the repository's main checkout:  bash docs/studies/build_robot.sh NAME
# The build's training scenes and its time so far live in out/NAME/, which a new machine
# does not have. This restores them from docs/studies/build_NAME/, where they are committed
# hourly as `data:`, and resumes the build: the data step keeps the scenes on disk, and a
# step cut off counts its time on. The robot's files under models/NAME/ are not committed
# here: look at them, then commit them.
set -euo pipefail
main="$(git rev-parse --show-toplevel)"
name="${1:?usage: build_robot.sh NAME}"
here="$main/docs/studies/build_$name"
out="$main/out/$name"
kept=(fcn_data fcn_data_dense build_time.json)
mkdir -p "$out"
for item in "${kept[@]}"; do
    if [ -e "$here/$item" ] && [ ! -e "$out/$item" ]; then cp -r "$here/$item" "$out/"; fi
done
(set +e; while sleep 3600; do
    mkdir -p "$here"
    for item in "${kept[@]}"; do
        [ -e "$out/$item" ] && rm -rf "$here/$item" && cp -r "$out/$item" "$here/"
    done
    scenes=$(ls "$out"/fcn_data/scene_*.npz "$out"/fcn_data_dense/scene_*.npz 2>/dev/null | wc -l)
    git -C "$main" add "$here"
    git -C "$main" commit -q -m "data: the $name build's training scenes so far: $scenes" -- "$here"
done) &
keeper=$!
trap 'kill $keeper 2>/dev/null' EXIT
cd "$main"
s3o build robot "$name" --workers 2
echo "the $name build: done"
