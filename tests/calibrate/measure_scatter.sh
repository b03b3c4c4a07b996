#!/bin/sh
# Counts what host_sim calibrate does with fixture scenarios over seeds: written without a word,
# written with a scatter warning (ratio 3..10, or motion), refused (a scatter between stations
# above 10), and the causes it names; for the thermal fixture also whether the coefficients were
# fitted. Usage: H=build/host/host_sim/app/host_sim tests/calibrate/measure_scatter.sh FIRST LAST [SCENARIO...]
H=${H:-build/host/host_sim/app/host_sim}
FIRST=${1:-1}; LAST=${2:-20}; shift 2
SCENARIOS=${*:-fixture fixture-ar1 fixture-drift fixture-one-distance fixture-realnoise fixture-thermal fixture-thermal-narrow fixture-thermal-blind}
D=$(mktemp -d)
for s in $SCENARIOS; do
  clean=0; warned=0; refused=0; fitted=0; temp=0; arm=0; motion=0; unseen=0; none=0; n=0
  for seed in $(seq "$FIRST" "$LAST"); do
    $H scenario "$s" --seed "$seed" --trace-out "$D/t.csv" || exit 2
    if $H calibrate "$D/t.csv" --out "$D/h.cal" 2> "$D/err"; then
      if grep -q 'scatter ratio.*likely cause' "$D/err"; then warned=$((warned + 1)); else clean=$((clean + 1)); fi
    else
      refused=$((refused + 1))
    fi
    grep -q 'temperature coefficient fitted' "$D/err" && fitted=$((fitted + 1))
    grep -q 'likely cause: temperature' "$D/err" && temp=$((temp + 1))
    grep -q 'likely cause: .*arm: its station' "$D/err" && arm=$((arm + 1))
    grep -q 'likely cause: .*motion: its readings' "$D/err" && motion=$((motion + 1))
    grep -q 'which this trace cannot show' "$D/err" && unseen=$((unseen + 1))
    grep -q 'not temperature, arm' "$D/err" && none=$((none + 1))
    n=$((n + 1))
  done
  echo "$s seeds $FIRST-$LAST: $n runs: written silently $clean, with a warning $warned, refused $refused; coefficients fitted $fitted; runs naming temperature $temp, arm $arm, motion $motion, temperature unseen (no temp_c) $unseen, no cause $none"
done
rm -rf "$D"
