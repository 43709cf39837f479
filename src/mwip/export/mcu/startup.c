/* Start-up of a bare Cortex-M3 (mwip.export.pil): the vector table and the reset handler,
 * which copies .data from flash to SRAM, zeroes .bss and calls main. No library start-up
 * code, no heap, no interrupts: the controller's step function runs from main's loop. */
extern unsigned int _sidata, _sdata, _edata, _sbss, _ebss, _estack;
int main(void);
void mwip_reset(void);
void mwip_fault(void);

void mwip_fault(void)
{
    for (;;) {
    }
}

/* Initial stack pointer, reset, NMI, hard fault, memory management, bus and usage faults. */
__attribute__((section(".vectors"), used)) void (*const mwip_vectors[7])(void) = {
    (void (*)(void))&_estack, mwip_reset, mwip_fault, mwip_fault,
    mwip_fault, mwip_fault, mwip_fault,
};

void mwip_reset(void)
{
    unsigned int *src = &_sidata, *dst = &_sdata;
    while (dst < &_edata) *dst++ = *src++;
    for (dst = &_sbss; dst < &_ebss; ++dst) *dst = 0;
    main();
    mwip_fault();
}
