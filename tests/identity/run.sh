#!/usr/bin/env bash
# Runs a fixed set of volmap commands into a folder, so that two builds can be compared byte for
# byte (see compare.sh). Every command a user runs to get a result is here: map, info, sample,
# features, every standard test, fit, build, compensate, trace, every export format, budget and
# the plots. What differs between two runs of one build (the seconds and Mpts/s a run reports,
# the date build and fit write) is replaced by a fixed word before anything is compared.
#
#   tests/identity/run.sh VOLMAP_BINARY OUT_FOLDER
set -euo pipefail
volmap=$(realpath "$1")
out=$2
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)
rm -rf "$out"
mkdir -p "$out"
out=$(realpath "$out")
cd "$out"
cp "$here"/inputs/* .
cp "$repo/examples/li2015-part.toml" part.toml
cp "$repo/examples/dobariya2015/test-piece.nc" piece.nc
cp "$repo/examples/dobariya2015/machine.toml" dobariya.toml
cp "$repo/examples/tolerances/vmc-li2015.toml" tolerances.toml
cp "$repo/examples/tolerances/5axis-hwang2014.toml" tolerances-5axis.toml

# One command: its stdout, stderr and exit code go to NAME.out, NAME.err, NAME.code.
run() {
  local name=$1
  shift
  set +e
  "$volmap" "$@" >"$name.out" 2>"$name.err"
  echo $? >"$name.code"
  set -e
}

run machines machines
for m in vmc-li2015 gantry-2m 5axis-hwang2014; do run "machines-$m" machines --show "$m"; done

# Maps: every compression, HALF, the GPU where there is one (compared only against the same
# device), a pose sweep, inputs, VTK.
run map-cpu map --machine vmc-li2015 --grid 9x7x5 --device cpu --out map-cpu.exr --vti map-cpu.vti
run map-zip map --machine gantry-2m --grid 8x8x8 --device cpu --compression zip --out map-zip.exr
run map-pxr24 map --machine vmc-li2015 --grid 17x9x5 --device cpu --compression pxr24 --out map-pxr24.exr
run map-half map --machine vmc-li2015 --grid 8x8x8 --device cpu --half --compression zip --out map-half.exr
run map-poses map --machine 5axis-hwang2014 --grid 5x5x5 --device cpu --poses B=0:30:15,C=0:90:90 --out map-poses.exr
run map-inputs map --machine gantry-2m --grid 6x6x6 --device cpu --temperatures "$(cat gantry-temps.txt)" --approach X=-,Y=- --check 50 --out map-inputs.exr
run map-gpu map --machine vmc-li2015 --grid 16x16x16 --device gpu --check 100 --out map-gpu.exr
for f in map-cpu map-zip map-pxr24 map-half map-poses map-inputs; do run "info-$f" info "$f.exr"; done

run sample-field sample --points points.csv --field map-cpu.exr --device cpu --out sample-field.csv
run sample-exact sample --points points.csv --exact --machine vmc-li2015 --out sample-exact.csv
run sample-exact5 sample --points points5.csv --exact --machine 5axis-hwang2014 --pose B=20,C=45

run features-field features --part part.toml --field map-cpu.exr --json features-field.json
run features-machine features --part part.toml --machine vmc-li2015 --json features-machine.json
run features-samples features --part part.toml --machine vmc-li2015 --tolerances tolerances.toml --samples 64 --seed 7 --device cpu --json features-samples.json

run test-positioning test positioning --machine vmc-li2015 --axis X --json test-positioning.json --plot test-positioning.svg
run test-positioning-c test positioning --machine 5axis-hwang2014 --axis C --json test-positioning-c.json
run test-diagonal test diagonal --machine vmc-li2015 --diagonal PPP --json test-diagonal.json --plot test-diagonal.svg
run test-diagonal-ft test diagonal --machine gantry-2m --from 100,100,50 --to 900,600,300 --points 12
run test-circular test circular --machine vmc-li2015 --plane XY --radius 150 --json test-circular.json --plot test-circular.svg
run test-circular-measured test circular --machine vmc-li2015 --plane XY --points 24 --measured circle-xy.csv --json test-circular-measured.json
run test-rtest test rtest --machine 5axis-hwang2014 --axis C --sphere 0,0,50 --json test-rtest.json --plot test-rtest.svg

run fit fit --machine vmc-li2015 --measurements fit.toml --out fitted.toml --json fit.json
run build build --base vmc-li2015 --axis X=x.csv --axis Z=z.csv --out built.toml

run compensate compensate --machine dobariya.toml --program piece.nc --work-offset G54=0,0,10 --out piece-comp.nc --json compensate.json
run compensate-vmc compensate --machine vmc-li2015 --program program.nc --work-offset G54=300,200,250 --out program-comp.nc --json compensate-vmc.json
run compensate-5 compensate --machine 5axis-hwang2014 --program program5.nc --work-offset G54=0,0,0 --orientation --angular-tolerance 1e-6 --out program5-comp.nc --json compensate-5.json
run trace trace --machine vmc-li2015 --program program.nc --work-offset G54=300,200,250 --out trace.csv --json trace.json --plot trace.svg
run trace-comp trace --machine dobariya.toml --program piece.nc --work-offset G54=0,0,10 --compensate --json trace-comp.json

for f in grid-csv klipper marlin fanuc-3d; do
  run "export-$f" export --machine vmc-li2015 --format "$f" --out "export-$f.txt" --json "export-$f.json"
done
for f in linuxcnc siemens heidenhain fanuc isg isg-axis; do
  run "export-$f" export --machine vmc-li2015 --format "$f" --out "export-$f" --json "export-$f.json"
done
run export-gantry-linuxcnc export --machine gantry-2m --format linuxcnc --points 33 --out export-gantry-linuxcnc
run export-gantry-siemens export --machine gantry-2m --format siemens --spacing 100 --out export-gantry-siemens
run export-sweep export --machine vmc-li2015 --format grid-csv --sweep-points 2,3,5,9 --plot export-sweep.svg --json export-sweep.json

run budget budget --machine vmc-li2015 --tolerances tolerances.toml --grid 9x9x9 --device cpu --json budget.json --plot budget.svg
run budget-samples budget --machine vmc-li2015 --tolerances tolerances.toml --grid 7x7x7 --device cpu --samples 200 --spec 0.14 --seed 3 --per-sample budget-samples.csv --json budget-samples.json
run budget-allocate budget --machine vmc-li2015 --tolerances tolerances.toml --grid 5x5x5 --device cpu --samples 100 --spec 0.14 --allocate --out allocated.toml
run budget-5 budget --machine 5axis-hwang2014 --tolerances tolerances-5axis.toml --grid 5x5x5 --device cpu --poses B=0:30:30

run plot-slice plot slice --field map-cpu.exr --normal z --quantity VE --out plot-slice.svg
run plot-slice-png plot slice --field map-cpu.exr --normal x --quantity VE.Y --out plot-slice.png
run plot-grid plot grid --machine vmc-li2015 --out plot-grid.svg

# What differs between runs of one build: seconds, rates and the date and time written.
find . -type f ! -name '*.exr' ! -name '*.png' ! -name '*.vti' -print0 | while IFS= read -r -d '' f; do
  sed -E -i \
    -e 's/[0-9]+(\.[0-9]+)?(e[-+]?[0-9]+)? ?(s|ms|µs|Mpts\/s|Mpts|pts\/s|moves\/s)\b/TIME/g' \
    -e 's/"(seconds|[a-z_]*_s|[a-z_]*seconds[a-z_]*|mpts_per_s|[a-z_]*_ms)": ?[-0-9.e+]+/"\1": TIME/g' \
    -e 's/[0-9]{4}-[0-9]{2}-[0-9]{2}[ T][0-9]{2}:[0-9]{2}(:[0-9]{2})?( ?UTC|Z)?/DATE/g' \
    -e 's/ETA [^ ]+/ETA/g' \
    "$f"
done
