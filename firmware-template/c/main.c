/* The C firmware: firmware-template's linear mode (src/linear.rs) written in C over a generated
 * controller's C API, linked from its static library with arm-none-eabi-gcc and newlib
 * (scripts/c-firmware.sh builds and runs it; docs/c-api.md).
 *
 * The plant is the controller's own model x(k+1) = F x(k) + G u(k) (NAME_model), integrated in double
 * from rest, measured exactly: the state under state feedback, C x behind a filter
 * (NAME_measurement_model). The reference holds state 2 at 1 and every other state at 0. This is
 * flight_sim::fly_linear without noise, operation for operation, so the commands are the Rust
 * firmware's bit for bit: every command is printed as the bits of its scalars (`U k b0 b1 ...`) and
 * hashed into RESULT's commands_fnv1a64. Each NAME_step is timed with the board's timer, as the Rust
 * firmware times Controller::step. RESULT has the Rust firmware's fields but the stack's.
 *
 * Built with -DCTL=name -DCTL_UP=NAME -DHEADER="name.h" -DSPEC_PATH="..." [-DCYCLES=n]; the spec's
 * text is assembled in from spec.toml on the assembler's include path, for spec_fnv1a64. */
#include <stdbool.h>
#include <stdint.h>

#include HEADER
#include "board.h"

#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#define FN(x) CAT(CTL, x)
#define UP(x) CAT(CTL_UP, x)

#define NX UP(_NX)
#define NU UP(_NU)
#define N UP(_N)
#if UP(_HAS_FILTER)
#define NY UP(_NY)
#else
#define NY NX
#endif

typedef FN(_real_t) real;

/* Control cycles flown: linear.rs's default, or -DCYCLES (scripts/c-firmware.sh --cycles). */
#ifndef CYCLES
#define CYCLES 100
#endif
/* Iterations of the timer calibration loop (2 instructions each), as the Rust firmware's. */
#define CALIB_ITERS 1000000u

__asm__(".section .rodata.spec_text,\"a\"\n"
        ".global spec_text\nspec_text:\n.incbin \"spec.toml\"\n"
        ".global spec_text_end\nspec_text_end:\n.previous\n");
extern const unsigned char spec_text[], spec_text_end[];

static FN(_controller_t) ctl;

/* Text on the board's serial port, `\n` as `\r\n` (console.rs). */
static void put_str(const char *s) {
    for (; *s; s++) {
        if (*s == '\n') {
            board_byte('\r');
        }
        board_byte(*s);
    }
}

static void put_u64(uint64_t v) {
    char digits[21];
    int i = 20;
    digits[i] = 0;
    do {
        digits[--i] = (char)('0' + v % 10);
        v /= 10;
    } while (v != 0);
    put_str(&digits[i]);
}

/* The low `digits` hex digits of v, lowercase (spec.rs's hex). */
static void put_hex(uint64_t v, int digits) {
    for (int shift = digits - 1; shift >= 0; shift--) {
        unsigned d = (unsigned)(v >> (4 * shift)) & 0xfu;
        board_byte((char)(d < 10 ? '0' + d : 'a' + d - 10));
    }
}

/* x in millionths, rounded, with its sign; null if not finite or too large (linear.rs's signed). */
static void put_signed_micro(double x) {
    double um = x * 1e6;
    if (!(um >= -1.8e19 && um < 1.8e19)) {
        put_str("null");
        return;
    }
    if (um < 0.0) {
        put_str("-");
        put_u64((uint64_t)(-um + 0.5));
    } else {
        put_u64((uint64_t)(um + 0.5));
    }
}

static uint64_t fnv1a64_byte(uint64_t h, uint8_t b) { return (h ^ b) * 0x00000100000001b3ull; }

/* The bits of a scalar, in a u64 (f32 or f64). */
static uint64_t bits(real v) {
    union {
        real r;
        uint32_t w32;
        uint64_t w64;
    } u = {.r = v};
    return sizeof(real) == 4 ? u.w32 : u.w64;
}

static bool finite(double v) { return v - v == 0.0; }

/* M v from -0.0, term by term in order: Rust's f64 Sum, as flight_sim's `product`. */
#define PRODUCT(out, m, v, rows, cols)                                                            \
    for (int i_ = 0; i_ < (rows); i_++) {                                                          \
        double s_ = -0.0;                                                                         \
        for (int j_ = 0; j_ < (cols); j_++) {                                                      \
            s_ += (double)(m)[i_][j_] * (v)[j_];                                                  \
        }                                                                                         \
        (out)[i_] = s_;                                                                           \
    }

/* Timer ticks a loop of exactly 2 * iters instructions takes. */
static uint32_t timed_loop(uint32_t iters) {
    uint32_t t0 = board_now();
    __asm__ volatile("1:\n\tsubs %0, %0, #1\n\tbne 1b" : "+r"(iters) : : "cc");
    return board_now() - t0;
}

static real f[NX][NX], g[NX][NU];
#if UP(_HAS_FILTER)
static real c[NY][NX];
#endif
static real xref[N][NX];

int main(void) {
    board_serial_init();
    board_timer_start();
    uint64_t calib_ticks = timed_loop(CALIB_ITERS);

    FN(_model)(f, g);
    double x[NX] = {0};
#if UP(_HAS_FILTER)
    FN(_measurement_model)(c);
    const real x0[NX] = {0};
    FN(_init)(&ctl, x0);
    const char *kind = "filter";
#else
    FN(_init)(&ctl);
    const char *kind = "state feedback";
#endif
    for (int k = 0; k < N; k++) {
        for (int i = 0; i < NX; i++) {
            xref[k][i] = (real)(i == 2 ? 1.0 : 0.0);
        }
    }
    uint64_t spec_hash = 0xcbf29ce484222325ull;
    for (const unsigned char *p = spec_text; p < spec_text_end; p++) {
        spec_hash = fnv1a64_byte(spec_hash, *p);
    }
    const char *scalar = sizeof(real) == 4 ? "f32" : "f64";

    put_str("firmware-template (C) on " BOARD_NAME "\nspec " SPEC_PATH ": linear model, ");
    put_str(kind);
    put_str(", ");
    put_str(scalar);
    put_str(", horizon ");
    put_u64(N);
    put_str(", ");
    put_u64(UP(_ITERATIONS));
    put_str(" iterations, ");
    put_u64(UP(_MACS_PER_CYCLE));
    put_str(" multiply-adds a cycle\nflying ");
    put_u64(CYCLES);
    put_str(" cycles from rest to state 2 = 1\n");

    uint64_t t_min = UINT64_MAX, t_max = 0, t_sum = 0, t_count = 0;
    uint64_t unsolved = 0, fell_back = 0, saturated = 0;
    uint64_t hash = 0xcbf29ce484222325ull;
    bool ok_finite = true;
    for (uint64_t k = 0; k < CYCLES; k++) {
        double y[NY];
#if UP(_HAS_FILTER)
        PRODUCT(y, c, x, NY, NX);
#else
        /* C = I: y = x exactly (the state is never -0.0, so no sign of zero is lost). */
        for (int i = 0; i < NX; i++) {
            y[i] = x[i];
        }
#endif
        real z[NY], u[NU];
        for (int i = 0; i < NY; i++) {
            z[i] = (real)y[i];
        }
        uint32_t t0 = board_now();
        int32_t code = FN(_step)(&ctl, z, (const real(*)[NX])xref, u);
        uint64_t ticks = board_now() - t0;
        t_min = ticks < t_min ? ticks : t_min;
        t_max = ticks > t_max ? ticks : t_max;
        t_sum += ticks;
        t_count++;

        FN(_status_t) status;
        FN(_status)(&ctl, &status);
        unsolved += code != UP(_COMMAND_SOLVED);
        fell_back += FN(_fell_back)(&ctl) == 1;
        bool any = false;
        for (int i = 0; i < NU; i++) {
            any |= status.saturated[i];
        }
        saturated += any;

        put_str("U ");
        put_u64(k);
        double ud[NU];
        for (int i = 0; i < NU; i++) {
            uint64_t b = bits(u[i]);
            put_str(" ");
            put_hex(b, 2 * (int)sizeof(real));
            for (int byte = 0; byte < 8; byte++) {
                hash = fnv1a64_byte(hash, (uint8_t)(b >> (8 * byte)));
            }
            ud[i] = (double)u[i];
            ok_finite &= finite(ud[i]);
        }
        put_str("\n");

        /* x <- F x + G u + w, w = 0 (LinearPlant::step). */
        double fx[NX], gu[NX];
        PRODUCT(fx, f, x, NX, NX);
        PRODUCT(gu, g, ud, NX, NU);
        for (int i = 0; i < NX; i++) {
            x[i] = fx[i] + gu[i] + 0.0;
        }
    }
    for (int i = 0; i < NX; i++) {
        ok_finite &= finite(x[i]);
    }
    bool ok = t_count == CYCLES && ok_finite && unsolved == 0;
    uint64_t t_mean = (t_sum + t_count / 2) / t_count;

    put_str("control cycle (MPC on the measured state), " BOARD_TIMER ": min ");
    put_u64(t_min);
    put_str(", mean ");
    put_u64(t_mean);
    put_str(", max ");
    put_u64(t_max);
    put_str("\nstatus: ");
    put_u64(unsolved);
    put_str(" cycles without a solve, ");
    put_u64(fell_back);
    put_str(" with the solver's fallback, ");
    put_u64(saturated);
    put_str(" with a saturated input\nfinal state 2, micro-units: ");
    put_signed_micro(NX > 2 ? x[2] : 0.0);
    put_str(ok ? "\nflight OK\n" : "\nflight FAILED\n");

    put_str("RESULT {\"mode\":\"linear\",\"language\":\"c\",\"spec\":\"" SPEC_PATH "\",\"spec_fnv1a64\":\"");
    put_hex(spec_hash, 16);
    put_str("\",\"board\":\"" BOARD_NAME "\",\"scalar\":\"");
    put_str(scalar);
    put_str("\",\"nx\":");
    put_u64(NX);
    put_str(",\"nu\":");
    put_u64(NU);
    put_str(",\"horizon\":");
    put_u64(N);
    put_str(",\"iterations\":");
    put_u64(UP(_ITERATIONS));
    put_str(",\"macs_per_iteration\":");
    put_u64(UP(_MACS_PER_ITERATION));
    put_str(",\"macs_per_cycle\":");
    put_u64(UP(_MACS_PER_CYCLE));
    put_str(",\"cycles\":");
    put_u64(t_count);
    put_str(",\"ticks_min\":");
    put_u64(t_min);
    put_str(",\"ticks_mean\":");
    put_u64(t_mean);
    put_str(",\"ticks_max\":");
    put_u64(t_max);
    put_str(",\"ticks_total\":");
    put_u64(t_sum);
    put_str(",\"calib_instructions\":");
    put_u64(2ull * CALIB_ITERS);
    put_str(",\"calib_ticks\":");
    put_u64(calib_ticks);
    put_str(",\"unsolved_cycles\":");
    put_u64(unsolved);
    put_str(",\"fallback_cycles\":");
    put_u64(fell_back);
    put_str(",\"saturated_cycles\":");
    put_u64(saturated);
    put_str(",\"commands_fnv1a64\":\"");
    put_hex(hash, 16);
    put_str("\",\"final_state_micro\":[");
    for (int i = 0; i < NX; i++) {
        if (i > 0) {
            put_str(",");
        }
        put_signed_micro(x[i]);
    }
    put_str(ok ? "],\"ok\":true}\n" : "],\"ok\":false}\n");
    return ok ? 0 : 1;
}
