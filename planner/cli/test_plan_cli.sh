#!/usr/bin/env bash
# ddsnav-plan end to end: one JSON line with the documented fields, an SVG, and a clear error with exit
# status 2 for every kind of bad input. Usage: test_plan_cli.sh PATH/TO/ddsnav-plan SOURCE_DIR
set -u
plan=$1
src=$2
scenarios=$src/configs/scenarios
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# Good run: exactly one line of JSON with the required fields, and a picture.
"$plan" --scenario "$scenarios/demo_2d.yaml" --planner rrtstar --seed 4 --json --svg "$tmp/run.svg" >"$tmp/out" 2>"$tmp/err" || fail "good run exited $?"
[ "$(wc -l <"$tmp/out")" -eq 1 ] || fail "JSON output is not exactly one line"
python3 - "$tmp/out" <<'PY' || fail "JSON fields"
import json, sys
d = json.loads(open(sys.argv[1]).read())
for k in ["scenario", "planner", "seed", "solved", "exact", "time_s", "iterations", "vertices", "cost", "pous", "por", "path",
          "fdc", "fgc", "coverage", "growth", "validity_checks", "kinodynamic"]:
    assert k in d, k
assert d["solved"] and d["exact"] and d["planner"] == "rrtstar" and d["seed"] == 4 and d["kinodynamic"] is False
assert all(len(s) == 3 for s in d["path"]), "2-D states are [x, y, theta]"
PY
grep -q "<svg" "$tmp/run.svg" || fail "no SVG written"
# 3-D states carry z.
"$plan" --scenario "$scenarios/gart_terrain_3d.yaml" --planner rrt --json >"$tmp/out3" || fail "3-D run exited $?"
python3 -c "import json,sys; d=json.load(open('$tmp/out3')); assert all(len(s)==4 for s in d['path'])" || fail "3-D states are [x, y, z, theta]"
# Same seed, same output (apart from timings).
for i in 1 2; do "$plan" --scenario "$scenarios/stunnel_0.5.yaml" --planner rrt --kinodynamic --seed 9 --json |
  python3 -c "import json,sys; d=json.load(sys.stdin); print(d['path'], d['iterations'])" >"$tmp/det$i"; done
cmp -s "$tmp/det1" "$tmp/det2" || fail "same seed gave different paths"

# Bad input: exit status 2 and a message naming the problem.
expect_error() {
  local words=$1; shift
  "$plan" "$@" >"$tmp/out" 2>"$tmp/err"
  local status=$?
  [ $status -eq 2 ] || fail "'$*' exited $status, expected 2"
  grep -q -- "$words" "$tmp/err" || fail "'$*' stderr lacks '$words': $(cat "$tmp/err")"
}
expect_error "unknown planner 'astar'" --scenario "$scenarios/demo_2d.yaml" --planner astar
expect_error "time-limit" --scenario "$scenarios/demo_2d.yaml" --planner rrt --time-limit 0
expect_error "time-limit" --scenario "$scenarios/demo_2d.yaml" --planner rrt --time-limit nan
expect_error "max-iterations" --scenario "$scenarios/demo_2d.yaml" --planner rrt --max-iterations 0
expect_error "cannot open" --scenario "$tmp/missing.yaml" --planner rrt
sed 's/^start: .*/start: [11, 10]/' "$scenarios/demo_2d.yaml" >"$tmp/start_in_box.yaml"
expect_error "start .* in collision" --scenario "$tmp/start_in_box.yaml" --planner rrt
sed 's/^goal: .*/goal: [60, 10]/' "$scenarios/demo_2d.yaml" >"$tmp/goal_out.yaml"
expect_error "goal_out.yaml:[0-9]*: key 'goal': outside bounds" --scenario "$tmp/goal_out.yaml" --planner rrt
sed 's/^bounds: .*/bounds: {min: [0, 0], max: [40, 0]}/' "$scenarios/demo_2d.yaml" >"$tmp/flat.yaml"
expect_error "degenerate bounds" --scenario "$tmp/flat.yaml" --planner rrt
sed 's/^robot_radius: .*/robot_radius: .nan/' "$scenarios/demo_2d.yaml" >"$tmp/nan.yaml"
expect_error "key 'robot_radius': expected a finite number" --scenario "$tmp/nan.yaml" --planner rrt
grep -v '^vehicle' "$scenarios/demo_2d.yaml" >"$tmp/novehicle.yaml"
expect_error "vehicle" --scenario "$tmp/novehicle.yaml" --planner rrt --kinodynamic

# No path: ends at the limit, solved false, exit 0.
cat >"$tmp/walled.yaml" <<'YAML'
dimensions: 2
bounds: {min: [0, 0], max: [20, 20]}
start: [2, 2]
goal: [15, 15]
goal_radius: 0.5
obstacles:
  - {type: box, min: [10, 0], max: [11, 20]}
YAML
"$plan" --scenario "$tmp/walled.yaml" --planner rrt --time-limit 0.2 --json >"$tmp/out" || fail "unsolvable run exited $?"
python3 -c "import json; d=json.load(open('$tmp/out')); assert d['solved'] is False and d['path'] == []" || fail "unsolvable run"

[ $failures -eq 0 ] && echo "all ddsnav-plan checks passed"
exit $failures
