#!/bin/sh
# Measures host_sim calibrate on a fixture scenario over seeds (docs/how-to/calibrate-a-head.md, "How long"):
# the mean stated offset sd, the RMS of the actual offset errors against the trace's
# sim_offset_mm, their ratio, and the readings per station the noise alone needs for 0.05 mm
# (--accept-scatter: the stated sd is measured also where a scatter between stations refuses it);
# for a thermal fit also the temperature coefficients against the trace's sim_temp_coeff_mm_per_c.
# Usage: H=build/host-release/host_sim/app/host_sim tests/calibrate/measure_fixture.sh [SCENARIO] [SEEDS]
H=${H:-build/host/host_sim/app/host_sim}
S=${1:-fixture}; N=${2:-50}; D=$(mktemp -d)
for seed in $(seq 1 $N); do
  $H scenario $S --seed $seed --trace-out $D/t.csv && $H calibrate $D/t.csv --accept-scatter --out $D/h.cal --report $D/r$seed.json 2>/dev/null
  grep '^# sim_' $D/t.csv > $D/truth$seed
done
python3 - "$D" "$N" "$S" <<'PY'
import json,sys,math
d,n,s=sys.argv[1],int(sys.argv[2]),sys.argv[3]
sd=[];err=[];z=[];need=[];infl=[];gsd=[];zk=[];ksd=[]
for i in range(1,n+1):
    r=json.load(open(f"{d}/r{i}.json"))
    t={}
    for l in open(f"{d}/truth{i}"):
        key,val=l[2:].strip().split('=',1)
        if key in ("sim_offset_mm","sim_gain","sim_temp_coeff_mm_per_c","sim_temp_ref_c"):
            t[key]=[float(v) for v in val.split(',')]
    thermal=r["thermal"]["fitted"]
    for k,x in enumerate(r["sensors"]):
        want=t["sim_offset_mm"][k]
        if thermal:  # the offset at cal_temp_c, the coefficient against the truth
            kt=t["sim_temp_coeff_mm_per_c"][k]
            want+=kt*(r["thermal"]["cal_temp_c"]-t["sim_temp_ref_c"][0])
            zk.append((x["temp_coeff_mm_per_c"]-kt)/x["temp_coeff_sd_mm_per_c"]); ksd.append(x["temp_coeff_sd_mm_per_c"])
        if r["fit"]!="offsets+gains": want+= (t["sim_gain"][k]-1)*r["distance_range_mm"][0]
        sd.append(x["offset_sd_mm"]); err.append(x["offset_mm"]-want); z.append(err[-1]/sd[-1])
        need.append(x["readings_per_station_for_0_05_mm"]); infl.append(x["inflation"])
        if x["gain_sd"] is not None: gsd.append(x["gain_sd"])
rms=lambda a: math.sqrt(sum(v*v for v in a)/len(a))
if zk: print(f"{s}: {len(zk)} temperature coefficients: mean stated sd {sum(ksd)/len(ksd):.5f} mm/C, RMS z {rms(zk):.3f}, max |z| {max(abs(v) for v in zk):.2f}")
print(f"{s}: {len(sd)} fits: mean stated offset sd {sum(sd)/len(sd):.4f} mm, RMS offset error {rms(err):.4f} mm, RMS z {rms(z):.3f}, max |z| {max(abs(v) for v in z):.2f}, mean gain sd {sum(gsd)/len(gsd) if gsd else float('nan'):.6f}, median readings/station for 0.05 mm {sorted(need)[len(need)//2]:.0f}, mean inflation {sum(infl)/len(infl):.2f}")
PY
rm -rf $D
