#!/usr/bin/env bash
# Instructions per simulated second (callgrind) of models/arm6.xml holding its standby pose: with
# steppers at the arm's own 1 ms step, with steppers at the step the timestep rule asks for, and
# models/arm6_servo.xml (MuJoCo's position servos) at 1 ms. Each is the difference of a 0.6 s and
# a 0.1 s run of `mjstepper run`, so loading and the modes' computation cancel.
#   bash bench/arm_cost.sh [BUILD_DIR]
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-$here/build}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
rule=$("$build/mjstepper" info "$here/models/arm6.xml" 2>/dev/null |
       sed -n 's/.*use timestep <= \([0-9.e-]*\) s.*/\1/p' | head -1)
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
  echo $(((long - short) * 2))
}
servo=$(per_second "$here/models/arm6_servo.xml")
own=$(per_second "$work/arm6.xml" --allow-coarse)
ruled=$(per_second "$work/arm6_rule.xml")
printf 'arm6_servo.xml at 1 ms:            %12d instructions per simulated second\n' "$servo"
printf 'arm6.xml steppers at 1 ms:         %12d (%.1f x)\n' "$own" "$(echo "$own / $servo" | bc -l)"
printf 'arm6.xml steppers at %s s: %12d (%.1f x)\n' "$rule" "$ruled" "$(echo "$ruled / $servo" | bc -l)"
