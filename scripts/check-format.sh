#!/usr/bin/env bash
# Checks that every C++ file is formatted as .clang-format says (Debian 12's clang-format
# 14, which scripts/install-deps.sh installs): prints the files that are not and a diff of
# the first, and exits 1 if there is one. Run as part of the tests (ctest format_check).
# To format: scripts/check-format.sh --fix
set -euo pipefail
cd "$(dirname "$0")/.."
clang_format=$(command -v clang-format-14 || command -v clang-format || true)
if [ -z "$clang_format" ]; then
  echo "check-format: clang-format not found (scripts/install-deps.sh installs it)" >&2
  exit 1
fi
mapfile -t files < <(git ls-files --cached --others --exclude-standard '*.cpp' '*.h' 2>/dev/null || find src calib mock_device service cli tests \( -name '*.cpp' -o -name '*.h' \))
if [ "${1:-}" = "--fix" ]; then
  "$clang_format" -i "${files[@]}"
  exit 0
fi
# One clang-format process for every file (one a file took 20 s of the suite, 3 s so).
status=0
report=$("$clang_format" --dry-run -Werror "${files[@]}" 2>&1) || status=$?
if [ "$status" -eq 0 ]; then
  echo "check-format: ${#files[@]} files formatted as .clang-format says"
  exit 0
fi
mapfile -t bad < <(sed -nE 's/^(.+):[0-9]+:[0-9]+: (error|warning): code should be clang-formatted.*/\1/p' <<<"$report" | sort -u)
if [ ${#bad[@]} -eq 0 ]; then
  echo "check-format: clang-format failed:" >&2
  echo "$report" | head -20 >&2
  exit 1
fi
echo "check-format: ${#bad[@]} of ${#files[@]} files differ from .clang-format (fix: scripts/check-format.sh --fix):"
printf '  %s\n' "${bad[@]}"
echo "first difference, in ${bad[0]}:"
"$clang_format" "${bad[0]}" | diff -u "${bad[0]}" - | head -40 || true
exit 1
