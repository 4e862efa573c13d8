# Sourced by the study scripts: a study's rows across sessions that end without warning.
# restore_rows HERE NAME...: each out/NAME/results.jsonl that is missing, from HERE/NAME/.
# keep_rows_hourly MAIN HERE LABEL NAME...: every hour, the rows back into HERE and one
#   `data:` commit in the checkout MAIN; it runs in the background until the script exits.
# enter_study MAIN HERE TREE COMMIT NAME...: into the worktree TREE at COMMIT (made if it is
#   missing), with that commit's package on the path, and the rows kept in HERE restored.
restore_rows() {
    local here="$1" name; shift
    for name in "$@"; do
        mkdir -p "out/$name"
        if [ -f "$here/$name/results.jsonl" ] && [ ! -f "out/$name/results.jsonl" ]; then
            cp "$here/$name/results.jsonl" "out/$name/"
        fi
    done
}
enter_study() {
    local main="$1" here="$2" tree="$3" commit="$4"; shift 4
    mkdir -p "$here"
    [ -d "$tree" ] || git -C "$main" worktree add --detach "$tree" "$commit"
    cd "$tree"
    export PYTHONPATH="$tree"  # this commit's package, not the editable install's
    restore_rows "$here" "$@"
}
keep_rows_hourly() {
    local main="$1" here="$2" label="$3"; shift 3
    # errexit off: a study folder without rows yet is no error here.
    (set +e; while sleep 3600; do
        local counts="" name
        for name in "$@"; do
            [ -s "out/$name/results.jsonl" ] || continue
            mkdir -p "$here/$name" && cp "out/$name/results.jsonl" "$here/$name/"
            counts="$counts$name $(wc -l < "out/$name/results.jsonl"), "
        done
        git -C "$main" add "$here"
        git -C "$main" commit -q -m "data: $label: ${counts%, } rows" -- "$here"
    done) &
    # The loop's sleep too, which would otherwise hold the script's output open for an hour.
    # shellcheck disable=SC2064
    trap "pkill -P $! 2>/dev/null; kill $! 2>/dev/null" EXIT
}
