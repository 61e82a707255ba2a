/* Replays a recorded flight through a generated controller's C API (tests/tests/c_api.rs).
 *
 * Built once per controller with -DCTL=name -DHEADER="name.h" -DNX=.. -DNU=.. -DN=.. -DNM=(length of
 * the measurement) and -DTAKES_X0=0|1. Reads from stdin: the cycle count, x0 (NX numbers, when
 * TAKES_X0), then per cycle NM measured values and N*NX reference values, every number as the hex of
 * its bits. Prints per cycle "step CODE U..." and at the end "plan P..." (bits in hex), so that the
 * Rust side compares bit for bit. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include HEADER

#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#define FN(x) CAT(CTL, x)

typedef FN(_real_t) real;

static FN(_controller_t) ctl;

/* Reads one number written as the hex of its bits; exits on malformed input. */
static real read_real(void) {
    unsigned long long bits;
    if (scanf("%llx", &bits) != 1) {
        fprintf(stderr, "replay: malformed or short input\n");
        exit(3);
    }
    real r;
    if (sizeof r == 4) {
        uint32_t w = (uint32_t)bits;
        memcpy(&r, &w, sizeof r);
    } else {
        uint64_t w = (uint64_t)bits;
        memcpy(&r, &w, sizeof r);
    }
    return r;
}

static void print_real(real r) {
    if (sizeof r == 4) {
        uint32_t w;
        memcpy(&w, &r, sizeof w);
        printf(" %08lx", (unsigned long)w);
    } else {
        uint64_t w;
        memcpy(&w, &r, sizeof w);
        printf(" %016llx", (unsigned long long)w);
    }
}

int main(void) {
    static real measured[NM];
    static real xref[N][NX];
    real u[NU];
    long cycles;
    if (scanf("%ld", &cycles) != 1 || cycles < 0) {
        fprintf(stderr, "replay: no cycle count\n");
        return 3;
    }
#if TAKES_X0
    real x0[NX];
    for (int i = 0; i < NX; i++) x0[i] = read_real();
    if (FN(_init)(&ctl, x0) != 0) return 4;
    if (FN(_init)(NULL, x0) >= 0) return 5; /* a null pointer is refused, not dereferenced */
#else
    if (FN(_init)(&ctl) != 0) return 4;
    if (FN(_init)(NULL) >= 0) return 5;
#endif
    for (long k = 0; k < cycles; k++) {
        for (int i = 0; i < NM; i++) measured[i] = read_real();
        for (int j = 0; j < N; j++)
            for (int i = 0; i < NX; i++) xref[j][i] = read_real();
        int32_t code = FN(_step)(&ctl, measured, (const real(*)[NX])xref, u);
        printf("step %ld", (long)code);
        for (int i = 0; i < NU; i++) print_real(u[i]);
        printf("\n");
    }
    static real plan[N][NU];
    if (FN(_plan)(&ctl, plan) != 0) return 6;
    printf("plan");
    for (int j = 0; j < N; j++)
        for (int i = 0; i < NU; i++) print_real(plan[j][i]);
    printf("\n");
    return 0;
}
