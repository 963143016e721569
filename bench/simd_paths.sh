#!/bin/sh
# One detection frame through every CNN inner-loop path, in one sequence of runs:
# the extension built portable (-DVT_NO_SIMD), SSE2 (-DVT_NO_AVX2), AVX2
# (-DVT_NO_AVXVNNI), 256-bit AVX-VNNI (-DVT_NO_AVX512) and with no flag (the best the
# CPU has), plus, when BEFORE names a
# commit, that commit's code. bench.py's stages detect_default, cnn_l0big_detect and
# cnn_detect; tables in OUT/<build>/b.md.
#
#   sh bench/simd_paths.sh OUT [BEFORE]      e.g. sh bench/simd_paths.sh /tmp/paths ed07639
set -e
OUT=${1:?usage: bench/simd_paths.sh OUT [BEFORE_COMMIT]}
BEFORE=${2:-}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
cd "$ROOT"
mkdir -p "$OUT"
PYINC=$(python3 -c "import sysconfig; print(sysconfig.get_paths()['include'])")
SUF=$(python3 -c "import sysconfig; print(sysconfig.get_config_var('EXT_SUFFIX'))")
build() { # name source-dir defines
  mkdir -p "$OUT/$1"
  (cd "$2" && python3 tools/build_ffi.py "$OUT/$1/_vtffi.c" >/dev/null &&
   cc -shared -fPIC -O2 $3 -Iinclude -I"$PYINC" c/*.c "$OUT/$1/_vtffi.c" -o "$OUT/$1/_vtffi$SUF")
}
NAMES="portable sse2 avx2 vnni256 best"
if [ -n "$BEFORE" ]; then
  rm -rf "$OUT/src-before"
  git worktree add -f --detach "$OUT/src-before" "$BEFORE" >/dev/null
  build before "$OUT/src-before" ""
  git worktree remove --force "$OUT/src-before"
  NAMES="before $NAMES"
fi
build portable . "-DVT_NO_SIMD"
build sse2 . "-DVT_NO_AVX2"
build avx2 . "-DVT_NO_AVXVNNI"
build vnni256 . "-DVT_NO_AVX512"
build best . ""
for n in $NAMES; do
  PYTHONPATH="$ROOT" PYVEHTRACK_FFI="$OUT/$n/_vtffi$SUF" python3 bench/bench.py --workdir "$OUT/work" \
    --stages detect_default,cnn_l0big_detect,cnn_detect --out "$OUT/$n/b" > "$OUT/$n/log" 2>&1
  echo "== $n ($(grep -o 'cnn inner loops[^|]*' "$OUT/$n/b.md" | head -1))"
  grep -E '^\| (detect_default|cnn_l0big_detect|cnn_detect) ' "$OUT/$n/b.md" | cut -d'|' -f2,6
done
