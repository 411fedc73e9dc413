#!/usr/bin/env bash
# Instructions per simulated second (callgrind) of models/arm6.xml holding its standby pose: with
# steppers at the arm's own 1 ms step, with steppers at the step the timestep rule asks for, and
# models/arm6_servo.xml (MuJoCo's position servos) at 1 ms. Each is the difference of a 0.6 s and
# a 0.1 s run of `mjstepper run`, so loading and the modes' computation cancel. Then the plugin
# alone (build/bench_step steps the models with no probe sensors, as a user's program would):
# both arms at 1 ms and at the rule's step, 8 s and 4 s of simulated time; the stepper arm with
# ideal current sources at 1 ms, and at 100 µs (two whole interrupt periods, beside the rule's step).
#   bash bench/arm_cost.sh [BUILD_DIR]
set -euo pipefail
shopt -s inherit_errexit  # a failing command inside $(...) stops the script too
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-$here/build}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
rule=$("$build/mjstepper" info "$here/models/arm6.xml" 2>/dev/null |
       sed -n 's/.*use timestep <= \([0-9.e-]*\) s.*/\1/p' | head -1)
[[ -n $rule ]] || { echo "arm_cost.sh: no timestep from mjstepper info" >&2; exit 1; }
sed "s/timestep=\"1e-3\"/timestep=\"$rule\"/" "$here/models/arm6.xml" > "$work/arm6_rule.xml"
cp "$here/models/arm6.xml" "$work/arm6.xml"  # beside it, as the rule's copy
count() {  # MODEL DURATION [OPTIONS...]: instructions of the whole run
  valgrind --tool=callgrind --callgrind-out-file="$work/cg" "$build/mjstepper" run "$1" \
    --duration "$2" --quiet "${@:3}" 2>&1 >/dev/null | sed -n 's/.*Collected : //p'
}
per_second() {  # MODEL [OPTIONS...]
  local short long
  short=$(count "$1" 0.1 "${@:2}")
  long=$(count "$1" 0.6 "${@:2}")
  [[ -n $short && -n $long ]] || { echo "arm_cost.sh: mjstepper run $1 failed" >&2; exit 1; }
  echo $(((long - short) * 2))
}
servo=$(per_second "$here/models/arm6_servo.xml")
own=$(per_second "$work/arm6.xml" --allow-coarse)
ruled=$(per_second "$work/arm6_rule.xml")
printf 'arm6_servo.xml at 1 ms:            %12d instructions per simulated second\n' "$servo"
printf 'arm6.xml steppers at 1 ms:         %12d (%.1f x)\n' "$own" "$(echo "$own / $servo" | bc -l)"
printf 'arm6.xml steppers at %s s: %12d (%.1f x)\n' "$rule" "$ruled" "$(echo "$ruled / $servo" | bc -l)"
bare() {  # STEPS MODEL [TIMESTEP]: instructions per simulated second of bench_step's 8 rounds
  local ir
  ir=$(valgrind --tool=callgrind --callgrind-out-file="$work/cg" --collect-atstart=no \
         --toggle-collect='*Round*' "$build/bench_step" "$@" 2>&1 >/dev/null |
       sed -n 's/.*Collected : //p')
  [[ -n $ir ]] || { echo "arm_cost.sh: bench_step $* failed" >&2; exit 1; }
  awk -v ir="$ir" -v n="$1" -v h="${3:-1e-3}" 'BEGIN { printf "%.0f", ir / (8 * n * h) }'
}
servo_bare=$(bare 1000 arm6_servo)
printf 'the plugin alone (bench_step):\n'
printf 'arm6_servo.xml at 1 ms:            %12d instructions per simulated second\n' "$servo_bare"
show() {  # STEPS MODEL [TIMESTEP]
  local n
  n=$(bare "$@")
  printf '%-14s at %-9s s:         %12d (%.1f x)\n' "$2" "${3:-0.001}" "$n" \
    "$(awk -v a="$n" -v b="$servo_bare" 'BEGIN { print a / b }')"
}
show 1000 arm6
show 5000 arm6_servo "$rule"
show 5000 arm6 "$rule"
show 1000 arm6_ideal
show 5000 arm6 1e-4
