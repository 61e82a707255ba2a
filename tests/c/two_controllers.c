/* Two generated controllers in one program (tests/tests/c_api.rs): both headers included, both static
 * libraries linked, no name in common. One step of each from fixed inputs; prints the commands' bits. */
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "paper.h"
#include "quadcopter.h"

static paper_controller_t paper;
static quadcopter_controller_t quad;

int main(void) {
    const float x0[PAPER_NX] = {0};
    const float z[PAPER_NY] = {0.25f, -0.5f, 1.0f};
    static float paper_ref[PAPER_N][PAPER_NX];
    float pu[PAPER_NU];
    const double x[QUADCOPTER_NX] = {0.1, -0.1, 0.0};
    static double quad_ref[QUADCOPTER_N][QUADCOPTER_NX];
    double qu[QUADCOPTER_NU];

    if (paper_init(&paper, x0) != 0 || quadcopter_init(&quad) != 0) return 2;
    int32_t a = paper_step(&paper, z, (const float(*)[PAPER_NX])paper_ref, pu);
    int32_t b = quadcopter_step(&quad, x, (const double(*)[QUADCOPTER_NX])quad_ref, qu);
    printf("paper %ld", (long)a);
    for (int i = 0; i < PAPER_NU; i++) {
        uint32_t w;
        memcpy(&w, &pu[i], 4);
        printf(" %08lx", (unsigned long)w);
    }
    printf("\nquadcopter %ld", (long)b);
    for (int i = 0; i < QUADCOPTER_NU; i++) {
        uint64_t w;
        memcpy(&w, &qu[i], 8);
        printf(" %016llx", (unsigned long long)w);
    }
    printf("\n");
    return 0;
}
