#!/usr/bin/env bash
# Compares the outputs of two builds of volmap over run.sh's commands, byte for byte (timings and
# dates aside): a restructuring that changes no behaviour passes it.
#
#   tests/identity/compare.sh REV             # REV (built in a worktree under target/) against
#                                             # this checkout's release build
#   tests/identity/compare.sh BEFORE AFTER    # two volmap binaries
#
# Exit 0 when every output is the same, 1 with the differences listed when one is not.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)
work="$repo/target/identity"
mkdir -p "$work"
if [ $# = 2 ]; then
  before=$1
  after=$2
elif [ $# = 1 ]; then
  rev=$(git -C "$repo" rev-parse --short "$1")
  tree="$work/tree-$rev"
  if [ ! -d "$tree" ]; then git -C "$repo" worktree add --detach "$tree" "$rev" >/dev/null; fi
  cargo build --release --quiet --manifest-path "$tree/Cargo.toml" --target-dir "$work/target-base"
  cargo build --release --quiet --manifest-path "$repo/Cargo.toml"
  before="$work/target-base/release/volmap"
  after="$repo/target/release/volmap"
else
  echo "usage: $0 REV | $0 BEFORE_BINARY AFTER_BINARY" >&2
  exit 2
fi
"$here/run.sh" "$before" "$work/before"
"$here/run.sh" "$after" "$work/after"
if diff -r "$work/before" "$work/after"; then
  echo "identity: $(find "$work/after" -type f | wc -l) outputs the same"
else
  echo "identity: the outputs differ (above)" >&2
  exit 1
fi
