/* board.c -- bare-metal start-up and console for the MPS2 boards under QEMU:
 * vector table, reset handler (copy .data, zero .bss, enable the FPU when built
 * for hard float, paint the stack), ARM semihosting through BKPT 0xAB, SysTick
 * as a tick counter, and the memcpy/memset/memmove the compiler may emit calls to.
 * Nothing here comes from a C library: the image links with -nostdlib -lgcc. */
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include "board.h"

int main(void);
void fw_reset_handler(void);
void fw_fault_handler(void);

/* Linker-script symbols (link.ld). Only their addresses mean anything. */
extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _sstack, _estack;

/* ---------------------------------------------------------------- vectors */
/* The core reads word 0 as the initial stack pointer and word 1 as the reset
 * address; a struct keeps the object pointer and the function pointers apart
 * without a non-ISO cast between them. */
typedef struct {
    const void *initial_sp;
    void (*handler[15])(void);
} fw_vector_table;

__attribute__((section(".isr_vector"), used))
const fw_vector_table fw_vectors = {
    &_estack,
    {
        fw_reset_handler, /* 1 reset */
        fw_fault_handler, /* 2 NMI */
        fw_fault_handler, /* 3 HardFault */
        fw_fault_handler, /* 4 MemManage */
        fw_fault_handler, /* 5 BusFault */
        fw_fault_handler, /* 6 UsageFault */
        0, 0, 0, 0,       /* 7-10 reserved */
        fw_fault_handler, /* 11 SVCall */
        fw_fault_handler, /* 12 DebugMonitor */
        0,                /* 13 reserved */
        fw_fault_handler, /* 14 PendSV */
        fw_fault_handler, /* 15 SysTick (never enabled as an interrupt) */
    },
};

#define FW_STACK_PAINT 0x5AA5F00Du

#define SCB_CPACR (*(volatile uint32_t *)0xE000ED88u)
#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)
#define SYST_MAX 0x00FFFFFFu

void fw_reset_handler(void)
{
    const uint32_t *src = &_sidata;
    uint32_t *dst;

    for (dst = &_sdata; (uintptr_t)dst < (uintptr_t)&_edata; ++dst, ++src) {
        *dst = *src;
    }
    for (dst = &_sbss; (uintptr_t)dst < (uintptr_t)&_ebss; ++dst) {
        *dst = 0;
    }
#if defined(__ARM_FP)
    /* Hard-float build: grant full access to CP10/CP11 before any VFP
     * instruction (the compiler may use them for spills), else UsageFault. */
    SCB_CPACR |= 0xFu << 20;
    __asm__ volatile("dsb\n\tisb" ::: "memory");
#endif
    fw_stack_paint();
    /* SysTick on the processor clock, free running, no interrupt. */
    SYST_RVR = SYST_MAX;
    SYST_CVR = 0;
    SYST_CSR = 0x5u; /* ENABLE | CLKSOURCE=processor */

    fw_exit(main() == 0);
}

void fw_fault_handler(void)
{
    fw_puts("fault: exception taken, stopping\n");
    fw_exit(0);
}

/* ---------------------------------------------------------------- semihosting */
#define SYS_WRITE0 0x04u
#define SYS_EXIT 0x18u
#define ADP_STOPPED_APPLICATION_EXIT 0x20026u
#define ADP_STOPPED_RUNTIME_ERROR_UNKNOWN 0x20023u

/* Operation in r0, argument in r1, result in r0; BKPT 0xAB is the M-profile trap. */
static uint32_t fw_semihost(uint32_t op, uintptr_t arg)
{
    register uint32_t r0 __asm__("r0") = op;
    register uintptr_t r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

void fw_puts(const char *s)
{
    fw_semihost(SYS_WRITE0, (uintptr_t)s);
}

void fw_exit(int ok)
{
    /* AArch32 SYS_EXIT takes the reason itself in r1; QEMU exits 0 only for
     * ApplicationExit. */
    fw_semihost(SYS_EXIT, ok ? ADP_STOPPED_APPLICATION_EXIT : ADP_STOPPED_RUNTIME_ERROR_UNKNOWN);
    for (;;) {
    }
}

/* ---------------------------------------------------------------- line formatter */
#define FW_LINE_MAX 100
static char fw_line[FW_LINE_MAX];
static size_t fw_line_len;

static void fw_line_char(char c)
{
    if (fw_line_len < FW_LINE_MAX - 2) { /* keep room for '\n' and NUL */
        fw_line[fw_line_len++] = c;
    }
}

void fw_line_str(const char *s)
{
    while (*s != '\0') {
        fw_line_char(*s++);
    }
}

void fw_line_u32(uint32_t v)
{
    char tmp[10];
    int n = 0;
    do {
        tmp[n++] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v != 0);
    while (n > 0) {
        fw_line_char(tmp[--n]);
    }
}

void fw_line_s32(int32_t v)
{
    if (v < 0) {
        fw_line_char('-');
        /* -(v + 1) + 1 in unsigned: the magnitude, INT32_MIN included. */
        fw_line_u32((uint32_t)(-(v + 1)) + 1u);
    } else {
        fw_line_u32((uint32_t)v);
    }
}

void fw_line_hex32(uint32_t v)
{
    static const char digits[] = "0123456789abcdef";
    int i;
    fw_line_str("0x");
    for (i = 28; i >= 0; i -= 4) {
        fw_line_char(digits[(v >> i) & 0xFu]);
    }
}

void fw_line_end(void)
{
    fw_line[fw_line_len++] = '\n';
    fw_line[fw_line_len] = '\0';
    fw_puts(fw_line);
    fw_line_len = 0;
}

/* ---------------------------------------------------------------- timing, stack */
uint32_t fw_ticks(void)
{
    return SYST_MAX - (SYST_CVR & SYST_MAX);
}

uint32_t fw_ticks_since(uint32_t start)
{
    return (fw_ticks() - start) & SYST_MAX;
}

/* Paint the free stack below the caller (64 bytes of margin below this
 * function's own frame) so fw_stack_used() can find the high-water mark. */
void fw_stack_paint(void)
{
    uint32_t *dst;
    uintptr_t sp;
    __asm__ volatile("mov %0, sp" : "=r"(sp));
    for (dst = &_sstack; (uintptr_t)dst < sp - 64u; ++dst) {
        *dst = FW_STACK_PAINT;
    }
}

uint32_t fw_stack_used(void)
{
    const uint32_t *p = &_sstack;
    while ((uintptr_t)p < (uintptr_t)&_estack && *p == FW_STACK_PAINT) {
        ++p;
    }
    return (uint32_t)((uintptr_t)&_estack - (uintptr_t)p);
}

uint32_t fw_stack_size(void)
{
    return (uint32_t)((uintptr_t)&_estack - (uintptr_t)&_sstack);
}

/* ---------------------------------------------------------------- mem* */
/* GCC may turn copy/clear loops and struct assignments into calls to these.
 * This file is compiled with -fno-tree-loop-distribute-patterns so the loops
 * below are not turned back into calls to themselves. */
void *memcpy(void *dst, const void *src, size_t n)
{
    unsigned char *d = dst;
    const unsigned char *s = src;
    while (n-- != 0) {
        *d++ = *s++;
    }
    return dst;
}

void *memmove(void *dst, const void *src, size_t n)
{
    unsigned char *d = dst;
    const unsigned char *s = src;
    if ((uintptr_t)d < (uintptr_t)s) {
        while (n-- != 0) {
            *d++ = *s++;
        }
    } else {
        while (n-- != 0) {
            d[n] = s[n];
        }
    }
    return dst;
}

void *memset(void *dst, int c, size_t n)
{
    unsigned char *d = dst;
    while (n-- != 0) {
        *d++ = (unsigned char)c;
    }
    return dst;
}
