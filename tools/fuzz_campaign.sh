#!/bin/sh
# The fuzzing campaign of docs/explanation/reliability.md: every libFuzzer target of the
# project for SECONDS each (default 600), two at a time (the machine has two
# cores), each on its committed seeds plus a corpus kept in OUT/<target>/corpus,
# then one table of executions per second, coverage and crashes.
#
#   tools/fuzz_campaign.sh BUILD_DIR [SECONDS] [OUT]
#     BUILD_DIR  a configured and built tree (cmake --preset host -B BUILD_DIR)
#     OUT        logs, corpora and any crash-*/timeout-*/leak-* inputs
#                (default BUILD_DIR/fuzz-long)
# Exit status 1 if any target failed (crash, timeout, leak, property violation).
# FUZZ_REPORT_ONLY=1 prints the table of an earlier run in OUT without fuzzing.
set -u
build=${1:?usage: fuzz_campaign.sh BUILD_DIR [SECONDS] [OUT]}
seconds=${2:-600}
out=${3:-$build/fuzz-long}
mkdir -p "$out"

# name|binary|seed dirs|flags, one line per target, written by the configure
# (tof_fuzz_target in cmake/TofFuzz.cmake).
manifest=$build/fuzz_targets.txt
if [ ! -s "$manifest" ]; then
    echo "fuzz_campaign.sh: $manifest is missing or empty: configure and build $build with" \
         "the fuzzers (clang and libclang-rt-14-dev, tools/setup.sh)" >&2
    exit 1
fi
targets=$(cat "$manifest")

run_one() { # name binary seeds extra
    name=$1
    [ "${FUZZ_REPORT_ONLY:-0}" = 1 ] && return
    bin=$2
    if [ ! -x "$bin" ]; then
        echo "$name: $bin not built" > "$out/$name.log"
        return
    fi
    mkdir -p "$out/$name/corpus"
    # shellcheck disable=SC2086  # $4 holds several flags
    "$bin" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
        -artifact_prefix="$out/$name/" $4 "$out/$name/corpus" $3 > "$out/$name.log" 2>&1
    echo "exit=$?" >> "$out/$name.log"
}

count=0
IFS='
'
for t in $targets; do
    [ -z "$t" ] && continue
    name=$(echo "$t" | cut -d'|' -f1)
    bin=$(echo "$t" | cut -d'|' -f2)
    seeds=$(echo "$t" | cut -d'|' -f3)
    extra=$(echo "$t" | cut -d'|' -f4)
    IFS=' '
    run_one "$name" "$bin" "$seeds" "$extra" &
    IFS='
'
    count=$((count + 1))
    if [ $((count % 2)) -eq 0 ]; then
        wait # this pair (the only children running)
    fi
done
wait

status=0
printf '| target | seconds | executions | exec/s | cov | ft | corpus | result |\n'
printf '|---|---|---|---|---|---|---|---|\n'
for t in $targets; do
    [ -z "$t" ] && continue
    name=$(echo "$t" | cut -d'|' -f1)
    log=$out/$name.log
    runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$')
    speed=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$')
    done_line=$(grep -E '[[:space:]]DONE[[:space:]]' "$log" | tail -n 1)
    cov=$(echo "$done_line" | sed -n 's/.*cov: \([0-9]*\).*/\1/p')
    ft=$(echo "$done_line" | sed -n 's/.*ft: \([0-9]*\).*/\1/p')
    corp=$(echo "$done_line" | sed -n 's/.*corp: \([^ ]*\).*/\1/p')
    result=ok
    if ! grep -q '^exit=0$' "$log"; then
        result="FAILED (see $log)"
        status=1
    fi
    printf '| %s | %s | %s | %s | %s | %s | %s | %s |\n' "$name" "$seconds" "${runs:-?}" \
        "${speed:-?}" "${cov:-?}" "${ft:-?}" "${corp:-?}" "$result"
done
exit $status
