#!/bin/sh
# ci-check.sh: run the shipped machines and check them against their golden results.
#
# Usage: sh scripts/ci-check.sh [OUTDIR]
#   exit 0 when every machine matches its golden, 1 on a regression or a failed run.
# The machines and their run options are listed in tests/data/golden/goldens.txt (the same
# list python tests/data/make_goldens.py writes the goldens from). The results and each
# check's JSON report stay in OUTDIR (default ci-results) as CI artifacts.
set -u
cd "$(dirname "$0")/.."
out=${1:-ci-results}
mkdir -p "$out"
status=0
grep -v '^[[:space:]]*#' tests/data/golden/goldens.txt | while read -r name machine options; do
    [ -n "$name" ] || continue
    golden="tests/data/golden/$name.h5"
    # shellcheck disable=SC2086
    camsim run "$machine" $options -o "$out/$name.h5" --check-against "$golden" --json \
        > "$out/$name.summary.json" 2> "$out/$name.log"
    rc=$?
    case $rc in
        0) echo "ok   $name" ;;
        1) echo "FAIL $name: regression or failed run, see $out/$name.log" >&2; exit 1 ;;
        *) echo "FAIL $name: could not run or compare (exit $rc), see $out/$name.log" >&2; exit 1 ;;
    esac
done || status=1
exit $status
