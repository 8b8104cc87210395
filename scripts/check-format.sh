#!/usr/bin/env bash
# Checks that the C++ sources of mesher/, fem/, needle/ and pipeline/ follow the repository's .clang-format
# (Debian clang-format 14): `clang-format --dry-run --Werror` on each file; exits non-zero and lists
# the places if any file would change. Fix with: clang-format -i <file>.
#   scripts/check-format.sh [paths...]     (default: mesher fem needle pipeline)
# Environment: CLANG_FORMAT (default: clang-format-14 if present, else clang-format).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
clang_format="${CLANG_FORMAT:-$(command -v clang-format-14 || command -v clang-format || true)}"
if [ -z "$clang_format" ]; then
  echo "check-format: clang-format (version 14) not found; install Debian's clang-format-14" >&2
  exit 2
fi
version=$("$clang_format" --version)
case "$version" in
  *"version 14."*) ;;
  *) echo "check-format: $clang_format is not clang-format 14 ($version); results would differ" >&2; exit 2 ;;
esac
paths=("$@")
[ ${#paths[@]} -eq 0 ] && paths=(mesher fem needle pipeline)
mapfile -t files < <(find "${paths[@]}" -type f \( -name '*.cpp' -o -name '*.hpp' -o -name '*.h' -o -name '*.cc' \) | sort)
if [ ${#files[@]} -eq 0 ]; then
  echo "check-format: no C++ sources under ${paths[*]}" >&2
  exit 2
fi
report=$("$clang_format" --style=file --dry-run --Werror "${files[@]}" 2>&1) && status=0 || status=$?
if [ "$status" -ne 0 ]; then
  printf '%s\n' "$report" | grep -E '^[^ ].*: (error|warning):' | sed 's/^/check-format: /' || printf '%s\n' "$report"
  n=$(printf '%s\n' "$report" | grep -cE ': (error|warning):' || true)
  echo "check-format: $n places in $(printf '%s\n' "$report" | grep -E ': (error|warning):' | cut -d: -f1 | sort -u | wc -l) files differ from .clang-format (fix: clang-format -i FILE)" >&2
  exit 1
fi
echo "check-format: ${#files[@]} files follow .clang-format"
