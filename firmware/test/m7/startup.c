// Start-up for the core's tests on QEMU's mps2-an500 (a Cortex-M7 with a double-precision FPU, like the
// i.MX RT1062): the vector table, the FPU switched on, then newlib's semihosting start-up (rdimon-crt0: stack,
// .bss, constructors, argv from QEMU's -semihosting-config arg=..., main, exit with main's status). A fault
// prints its registers and exits with status 70, so a crash fails its test instead of hanging QEMU.
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

extern void _start(void);
extern uint32_t __stack;

#define SCB_CPACR (*(volatile uint32_t*)0xE000ED88u)
#define SCB_CFSR (*(volatile uint32_t*)0xE000ED28u)
#define SCB_HFSR (*(volatile uint32_t*)0xE000ED2Cu)

void Reset_Handler(void) {
    SCB_CPACR |= 0xFu << 20;  // CP10 and CP11 (the FPU): full access, as Teensyduino's ResetHandler does
    __asm volatile("dsb\n\tisb");
    _start();
}

void Fault_Handler(void) {
    printf("fault: CFSR %08lx HFSR %08lx\n", (unsigned long)SCB_CFSR, (unsigned long)SCB_HFSR);
    exit(70);
}

typedef void (*Handler)(void);
__attribute__((section(".vectors"), used)) const Handler vectors[16] = {
    (Handler)(uintptr_t)&__stack, Reset_Handler, Fault_Handler, Fault_Handler,
    Fault_Handler, Fault_Handler, Fault_Handler,
};
