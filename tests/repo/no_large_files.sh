#!/usr/bin/env bash
# The repository holds source, not outputs: no tracked file over 1 MiB (the largest, CHANGELOG.md, is ≈ 90 kB).
# A 65 MB ULog named '--no-figures' once landed unnoticed (a flag took the next option as its file). Skipped,
# with a note, outside a git checkout (a source tarball).
set -euo pipefail
repo="$1"
limit=$((1024 * 1024))
if ! git -C "$repo" rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  echo "not a git checkout: nothing to check"; exit 0
fi
found=0
while IFS= read -r -d '' f; do
  [[ -f "$repo/$f" ]] || continue
  size=$(stat -c %s -- "$repo/$f")
  if ((size > limit)); then
    echo "tracked file over 1 MiB: '$f' ($size bytes)"; found=1
  fi
done < <(git -C "$repo" ls-files -z)
((found == 0)) && echo "no tracked file over 1 MiB"
exit "$found"
