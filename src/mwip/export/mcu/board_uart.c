/* Whole-board firmware (mwip.export.pil, QEMU's lm3s6965evb): the controller's step function
 * served over UART0 (0x4000C000, the Stellaris UART, a PL011) in binary frames.
 *
 *   board -> host at start:  "MWIP" <sizeof(mwip_real)>                       (5 bytes)
 *   host  -> board:          'I' y[8]        board -> host: 'i'               (init)
 *   host  -> board:          'S' t y[8]      board -> host: 's' u[2]          (one step)
 *   host  -> board:          'Q'             board -> host: 'q', then it stops (semihosting)
 *
 * Numbers are mwip_real in the processor's byte order (little-endian). Compiled with
 * -DMWIP_PREFIX=<prefix> -include <prefix>.h. */
#define MWIP_CAT_(a, b) a##b
#define MWIP_CAT(a, b) MWIP_CAT_(a, b)
#define MWIP_P(x) MWIP_CAT(MWIP_PREFIX, x)

#define REG(a) (*(volatile unsigned int *)(a))
#define SYSCTL_RCGC1 REG(0x400FE104u)
#define SYSCTL_RCGC2 REG(0x400FE108u)
#define GPIOA_AFSEL REG(0x40004420u)
#define GPIOA_DEN REG(0x4000451Cu)
#define UART0_DR REG(0x4000C000u)
#define UART0_FR REG(0x4000C018u)
#define UART0_IBRD REG(0x4000C024u)
#define UART0_FBRD REG(0x4000C028u)
#define UART0_LCRH REG(0x4000C02Cu)
#define UART0_CTL REG(0x4000C030u)
#define FR_RXFE 0x10u
#define FR_TXFF 0x20u

static MWIP_P(_state) state;
static union {
    mwip_real r[11];
    unsigned char b[11 * sizeof(mwip_real)];
} buf;

static void uart_init(void)
{
    SYSCTL_RCGC1 |= 1u;            /* UART0 clock */
    SYSCTL_RCGC2 |= 1u;            /* GPIO port A clock */
    GPIOA_AFSEL |= 3u;             /* PA0/PA1: U0Rx/U0Tx */
    GPIOA_DEN |= 3u;
    UART0_CTL = 0;
    UART0_IBRD = 27;               /* 115200 baud from 50 MHz: 50e6 / (16 * 115200) = 27.13 */
    UART0_FBRD = 8;
    UART0_LCRH = 0x70u;            /* 8 data bits, FIFOs on, no parity, 1 stop bit */
    UART0_CTL = 0x301u;            /* UART, transmit and receive enabled */
}

static unsigned char get(void)
{
    while (UART0_FR & FR_RXFE) {
    }
    return (unsigned char)UART0_DR;
}

static void put(unsigned char c)
{
    while (UART0_FR & FR_TXFF) {
    }
    UART0_DR = c;
}

static void get_n(unsigned char *p, unsigned int n)
{
    while (n--) *p++ = get();
}

static void put_n(const unsigned char *p, unsigned int n)
{
    while (n--) put(*p++);
}

/* Semihosting SYS_EXIT (ADP_Stopped_ApplicationExit): QEMU ends with status 0. */
static void stop(void)
{
    register unsigned int r0 __asm__("r0") = 0x18u;
    register unsigned int r1 __asm__("r1") = 0x20026u;
    __asm__ volatile("bkpt 0xAB" : : "r"(r0), "r"(r1) : "memory");
    for (;;) {
    }
}

int main(void)
{
    const unsigned int n = sizeof(mwip_real);
    uart_init();
    put_n((const unsigned char *)"MWIP", 4);
    put((unsigned char)n);
    for (;;) {
        const unsigned char cmd = get();
        if (cmd == 'I') {
            get_n(buf.b, 8 * n);
            MWIP_P(_init)(&state, buf.r);
            put('i');
        } else if (cmd == 'S') {
            get_n(buf.b, 9 * n);
            MWIP_P(_step)(&state, buf.r[0], buf.r + 1, buf.r + 9);
            put('s');
            put_n(buf.b + 9 * n, 2 * n);
        } else if (cmd == 'Q') {
            put('q');
            while (!(UART0_FR & 0x80u)) { /* until the transmit FIFO is empty (TXFE) */
            }
            stop();
        }
    }
}
