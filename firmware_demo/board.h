/* board.h -- the little the demo needs from a bare Cortex-M: ARM semihosting
 * output and exit (through the debugger trap, so no UART driver and no libc),
 * a tick counter, and the stack high-water mark.
 *
 * Cost: 100 bytes of RAM (one line buffer), a few hundred bytes of code. */
#ifndef FW_BOARD_H
#define FW_BOARD_H

#include <stdint.h>

/* Write a NUL-terminated string to the host console (SYS_WRITE0). */
void fw_puts(const char *s);

/* Build one output line piece by piece, then fw_line_end() writes it with a
 * single semihosting trap (one trap per character would be slow). */
void fw_line_str(const char *s);
void fw_line_u32(uint32_t v);    /* decimal */
void fw_line_s32(int32_t v);     /* decimal, '-' when negative */
void fw_line_hex32(uint32_t v);  /* 0x%08x */
void fw_line_end(void);

/* End the program: QEMU exits with status 0 if ok != 0, else 1. */
void fw_exit(int ok);

/* Processor-clock ticks since an arbitrary origin (SysTick, 24 bits, counting
 * up here). Differences are valid modulo 2^24 (see fw_ticks_since). */
uint32_t fw_ticks(void);
uint32_t fw_ticks_since(uint32_t start);

/* Bytes of the reserved stack ever written (painted at reset, scanned here). */
uint32_t fw_stack_used(void);
/* Paint the free stack again (done at reset), so that fw_stack_used() then
 * measures only what runs after this call. */
void fw_stack_paint(void);
/* Bytes of the reserved stack. */
uint32_t fw_stack_size(void);

#endif /* FW_BOARD_H */
