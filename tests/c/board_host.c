/* board_host.c -- firmware_demo/board.h on a hosted C library, so the
 * firmware's main.c (its checksum recipe over the primitives and the lane ->
 * detect -> track pipeline on three real frames in its "flash") runs unchanged
 * on the host under any compiler and flags. tests/test_determinism.py builds it
 * under gcc -O0/-O3, clang -O2/-O3 -march=native and -m32 and compares every
 * checksum and pipeline line with the Cortex-M3/M7 images under QEMU.
 * No clock, no stack painting: those lines (insns, stack) are not compared. */
#include <stdio.h>
#include <stdlib.h>
#include "board.h"

void fw_puts(const char *s)
{
    fputs(s, stdout);
}

void fw_line_str(const char *s)
{
    fputs(s, stdout);
}

void fw_line_u32(uint32_t v)
{
    printf("%lu", (unsigned long)v);
}

void fw_line_s32(int32_t v)
{
    printf("%ld", (long)v);
}

void fw_line_hex32(uint32_t v)
{
    printf("0x%08lx", (unsigned long)v);
}

void fw_line_end(void)
{
    fputc('\n', stdout);
}

void fw_exit(int ok)
{
    exit(ok ? 0 : 1);
}

uint32_t fw_ticks(void)
{
    return 0u;
}

uint32_t fw_ticks_since(uint32_t start)
{
    return 0u - start;
}

uint32_t fw_stack_used(void)
{
    return 0u;
}

void fw_stack_paint(void)
{
}

uint32_t fw_stack_size(void)
{
    return 0u;
}
