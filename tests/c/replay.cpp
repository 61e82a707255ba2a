// replay.c through the C++ header (tests/tests/c_api.rs): the same input, the same output, by the
// class CTL::Controller and its std::array overloads instead of the C functions.
//
// Built with -DCTL=name -DHEADER="name.hpp" -DTAKES_X0=0|1 -DMEASURED=Measurement|State.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include HEADER

namespace c = CTL;

// Reads one number written as the hex of its bits; exits on malformed input.
static c::Real read_real() {
    unsigned long long bits;
    if (std::scanf("%llx", &bits) != 1) {
        std::fprintf(stderr, "replay: malformed or short input\n");
        std::exit(3);
    }
    c::Real r;
    if (sizeof r == 4) {
        std::uint32_t w = static_cast<std::uint32_t>(bits);
        std::memcpy(&r, &w, sizeof r);
    } else {
        std::uint64_t w = static_cast<std::uint64_t>(bits);
        std::memcpy(&r, &w, sizeof r);
    }
    return r;
}

static void print_real(c::Real r) {
    if (sizeof r == 4) {
        std::uint32_t w;
        std::memcpy(&w, &r, sizeof w);
        std::printf(" %08lx", static_cast<unsigned long>(w));
    } else {
        std::uint64_t w;
        std::memcpy(&w, &r, sizeof w);
        std::printf(" %016llx", static_cast<unsigned long long>(w));
    }
}

static c::Window xref;

int main() {
    long cycles;
    if (std::scanf("%ld", &cycles) != 1 || cycles < 0) {
        std::fprintf(stderr, "replay: no cycle count\n");
        return 3;
    }
#if TAKES_X0
    c::State x0;
    for (auto& v : x0) v = read_real();
    static c::Controller ctl(x0);
#else
    static c::Controller ctl;
#endif
    c::MEASURED measured;
    for (long k = 0; k < cycles; k++) {
        for (auto& v : measured) v = read_real();
        for (auto& row : xref)
            for (auto& v : row) v = read_real();
        // Alternate the two overloads: both must give the same commands.
        c::Input u;
        std::int32_t code;
        if (k % 2 == 0) {
            code = ctl.step(measured, xref, u);
        } else {
            u = ctl.step(measured, xref);
            code = ctl.status().command;
        }
        std::printf("step %ld", static_cast<long>(code));
        for (auto v : u) print_real(v);
        std::printf("\n");
    }
    std::printf("plan");
    for (const auto& row : ctl.plan())
        for (auto v : row) print_real(v);
    std::printf("\n");
    return 0;
}
