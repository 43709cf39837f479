/* Processor-in-the-loop harness (mwip.export.pil, run in the unicorn emulator): the host
 * writes the sample time and the measurement into mwip_pil_io, calls mwip_pil_init once and
 * mwip_pil_step every sample (each returning to mwip_pil_halt), and reads the torques back.
 * Compiled with -DMWIP_PREFIX=<prefix> -include <prefix>.h. */
#define MWIP_CAT_(a, b) a##b
#define MWIP_CAT(a, b) MWIP_CAT_(a, b)
#define MWIP_P(x) MWIP_CAT(MWIP_PREFIX, x)

struct mwip_pil_io {
    mwip_real t;
    mwip_real y[8];
    mwip_real u[2];
};

__attribute__((used)) struct mwip_pil_io mwip_pil_io;
__attribute__((used)) MWIP_P(_state) mwip_pil_state;
__attribute__((used)) const unsigned int mwip_pil_state_size = sizeof(MWIP_P(_state));
__attribute__((used)) const unsigned int mwip_pil_real_size = sizeof(mwip_real);

void mwip_pil_halt(void);
void mwip_pil_init(void);
void mwip_pil_step(void);

__attribute__((noinline, used)) void mwip_pil_halt(void)
{
    for (;;) {
    }
}

__attribute__((noinline, used)) void mwip_pil_init(void)
{
    MWIP_P(_init)(&mwip_pil_state, mwip_pil_io.y);
}

__attribute__((noinline, used)) void mwip_pil_step(void)
{
    MWIP_P(_step)(&mwip_pil_state, mwip_pil_io.t, mwip_pil_io.y, mwip_pil_io.u);
}

int main(void)
{
    mwip_pil_halt();
    return 0;
}
