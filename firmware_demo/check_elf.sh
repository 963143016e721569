#!/bin/sh
# check_elf.sh LABEL FILE... -- fail if a firmware image or object links or
# references anything it must not:
#   - a heap (malloc/calloc/realloc/free, or newlib's _malloc_r & co.): the core
#     promises static memory only;
#   - a libgcc soft-float routine (__aeabi_f*/__aeabi_d*, __addsf3, __fixdfsi, ...):
#     the core promises no float, and on a soft-float Cortex-M3 any float or
#     double operation anywhere would pull one in;
#   - a floating-point instruction (.f16/.f32/.f64 data types, vcvt): the same
#     promise on the hard-float Cortex-M7, where no helper would be needed.
# Give it the linked image and every core object: the image shows what was
# linked, the objects also catch code the demo does not call (--gc-sections
# drops it from the image), through their undefined symbols.
# Uses FW_NM and FW_OBJDUMP from the environment (default: arm-none-eabi-*).
set -eu
label=$1
shift
nm=${FW_NM:-arm-none-eabi-nm}
objdump=${FW_OBJDUMP:-arm-none-eabi-objdump}

heap='^(malloc|calloc|realloc|free|_(malloc|calloc|realloc|free)_r|_sbrk|_sbrk_r|sbrk)$'
softfloat='^__aeabi_([fd]|c[fd]|u?[il]2[fd]|h2f)|^__(add|sub|mul|div|neg|cmp|eq|ne|lt|le|gt|ge|unord|fix|fixuns|extend|trunc|pow|powi)[sdtxh]f|^__float(un)?[sdt]i[sdtxh]f|^__(mul|div)[sdtx]c3'

syms=$("$nm" "$@" | awk 'NF >= 2 {print $NF}')
bad_heap=$(printf '%s\n' "$syms" | grep -E "$heap" | sort -u || true)
bad_float=$(printf '%s\n' "$syms" | grep -E "$softfloat" | sort -u || true)
bad_insn=$("$objdump" -d "$@" | grep -E '	v[a-z0-9]+(\.[a-z0-9]+)*\.f(16|32|64)[ 	]|	vcvt' | head -5 || true)

fail=0
if [ -n "$bad_heap" ]; then
    echo "symbol check $label: FAIL: heap functions linked or referenced:" $bad_heap >&2
    fail=1
fi
if [ -n "$bad_float" ]; then
    echo "symbol check $label: FAIL: soft-float helpers linked or referenced:" $bad_float >&2
    fail=1
fi
if [ -n "$bad_insn" ]; then
    echo "symbol check $label: FAIL: floating-point instructions:" >&2
    printf '%s\n' "$bad_insn" >&2
    fail=1
fi
if [ $fail -ne 0 ]; then
    exit 1
fi
echo "symbol check $label: OK ($# files; no malloc/calloc/realloc/free, no soft-float helper, no FP instruction)"
