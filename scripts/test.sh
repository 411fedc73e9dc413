#!/usr/bin/env bash
# Installs what is missing, builds everything and runs every test (GoogleTest and Python under
# ctest), then checks that no test left a process behind (issue 32, item 7): every process ctest
# starts inherits MJSTEPPER_TEST_RUN, so any process still carrying it after ctest has returned
# (an orphaned viewer, ffmpeg, a Ray worker, an X server) is named, stopped, and fails the run.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$here/scripts/build.sh"
cd "$here/build"
export MJSTEPPER_TEST_RUN="$$-$(date +%s%N)"
status=0
ctest --output-on-failure --parallel 2 || status=$?
sleep 1  # what a finished test stopped has a moment to exit
left=()
for environ in /proc/[0-9]*/environ; do
  pid=${environ#/proc/}
  pid=${pid%/environ}
  [[ $pid == "$$" || $pid == "$BASHPID" ]] && continue
  if tr '\0' '\n' 2>/dev/null < "$environ" | grep -qx "MJSTEPPER_TEST_RUN=$MJSTEPPER_TEST_RUN"; then
    left+=("$pid")
  fi
done
if (( ${#left[@]} > 0 )); then
  echo "tests left ${#left[@]} process(es) behind:" >&2
  ps -o pid,etime,args -p "$(IFS=,; echo "${left[*]}")" >&2 || true
  kill "${left[@]}" 2>/dev/null || true
  exit 1
fi
exit "$status"
