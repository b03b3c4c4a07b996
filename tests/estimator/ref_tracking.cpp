/*
 * The Kalman filter's tracking form against the optimal linear filter, written
 * here in double precision with Eigen: the same random-walk model (identity dynamics,
 * Q = diag(q_x̄, q_t, q_t)·period, rows of Eq. 5 with the slopes scaled by a) with the
 * true q and R = σ² + 1/12 (whole-mm readings: the rounding adds 1/12 mm²), all four
 * readings of a row in one batch update K = P⁻Hᵀ(HP⁻Hᵀ + R)⁻¹.
 *
 *   reading for reading  the fixed filter with the true q and R vs the double filter:
 *                        state within 0.01 mm on every row after the warm-up (the
 *                        steady state keeps gains within 2^-8 of the fixed point's,
 *                        kalman_track.c: about 2e-3 mm; the estimates' own error is
 *                        0.15 mm or more in every scenario)
 *   at the optimum       RMS(α), RMS(β) of the fixed filter over RMS of the optimal one,
 *                        per scenario (three seeds each): ≤ 1.05 with the true q,
 *                        ≤ 1.10 with `auto` (which starts from Q = 0 and R = 4 mm² and
 *                        learns both: kalman_track.c)
 *   auto converging      a scenario whose q_t grows 40x halfway: the second half within
 *                        1.10 of the optimal filter that knows the new q
 *
 * Scenarios (period 20 ms, a = 30 mm, 6000 rows, the first 500 not scored): slow and fast
 * random-walk motion, one sensor three times noisier, and an approach from 300 to 60 mm
 * at constant speed with the tilt wandering (its x̄ is not a random walk; both filters get
 * the same q_x̄). The table it prints is docs/explanation/accuracy.md's tracking table.
 */
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>

extern "C" {
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>

#include <cmocka.h>

#include "estimator/kalman.h"
}

/* int indices into std::array, std::vector and Eigen (signed Index) alike: sign
 * conversions are the norm in this file; every other warning stays an error */
#pragma GCC diagnostic ignored "-Wsign-conversion"

namespace {

constexpr double kQ32 = 4294967296.0;
constexpr double kArm = 30.0;
constexpr double kPeriod = 0.020;
int kRows = 6000; /* rows per run: ref_tracking --sweep A B ROWS changes it */
constexpr int kBurn = 500;
constexpr double kPi = 3.14159265358979323846;

struct Scenario {
    const char *name;
    double qd, qt;   /* mm²/s: the random walk of x̄ and of a·tan α, a·tan β */
    double qt_after; /* q_t from the middle on (the q-change scenario), else = qt */
    std::array<double, 4> sigma;
    bool approach; /* x̄ from 300 to 60 mm at constant speed */
};

const Scenario kScenarios[] = {
    {"slow motion", 0.5, 0.05, 0.05, {1.0, 1.0, 1.0, 1.0}, false},
    {"fast motion", 20.0, 5.0, 5.0, {1.0, 1.0, 1.0, 1.0}, false},
    {"one sensor 3x noisier", 2.0, 0.5, 0.5, {1.0, 1.0, 3.0, 1.0}, false},
    {"approach 300 to 60 mm", 4.0, 0.2, 0.2, {1.0, 1.0, 1.0, 1.0}, true},
};
const Scenario kChange = {"q_t x40 halfway", 1.0, 0.05, 2.0, {1.0, 1.0, 1.0, 1.0}, false};

struct Trace {
    std::vector<std::array<uint16_t, 4>> z;
    std::vector<std::array<double, 3>> truth; /* x̄, a·tan α, a·tan β */
};

const int kH[4][3] = {{1, -1, 0}, {1, 0, 1}, {1, 1, 0}, {1, 0, -1}};

Trace make_trace(const Scenario &sc, uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> n01(0.0, 1.0);
    Trace t;
    std::array<double, 3> th = {300.0, 0.0, 0.0};
    for (int i = 0; i < kRows; ++i) {
        const double qt = i < kRows / 2 ? sc.qt : sc.qt_after;
        if (sc.approach) {
            th[0] = 300.0 - 240.0 * i / (kRows - 1);
        } else {
            th[0] += std::sqrt(sc.qd * kPeriod) * n01(rng);
        }
        th[1] += std::sqrt(qt * kPeriod) * n01(rng);
        th[2] += std::sqrt(qt * kPeriod) * n01(rng);
        std::array<uint16_t, 4> z{};
        for (int s = 0; s < 4; ++s) {
            const double x = kH[s][0] * th[0] + kH[s][1] * th[1] + kH[s][2] * th[2];
            z[s] = (uint16_t)std::lround(x + sc.sigma[s] * n01(rng));
        }
        t.z.push_back(z);
        t.truth.push_back(th);
    }
    return t;
}

/* The optimal filter: double, batch update of the row, the true q (per half) and R. */
std::vector<std::array<double, 3>> optimal(const Scenario &sc, const Trace &t) {
    Eigen::Matrix3d P = Eigen::Matrix3d::Identity() * 16777216.0;
    Eigen::Vector3d x(0.0, 0.0, 0.0);
    Eigen::Matrix<double, 4, 3> H;
    Eigen::Matrix4d R = Eigen::Matrix4d::Zero();
    for (int s = 0; s < 4; ++s) {
        H.row(s) << kH[s][0], kH[s][1], kH[s][2];
        R(s, s) = sc.sigma[s] * sc.sigma[s] + 1.0 / 12.0;
    }
    std::vector<std::array<double, 3>> out;
    for (int i = 0; i < kRows; ++i) {
        const double qt = i < kRows / 2 ? sc.qt : sc.qt_after;
        P += Eigen::Vector3d(sc.qd, qt, qt).asDiagonal().toDenseMatrix() * kPeriod;
        Eigen::Vector4d z;
        for (int s = 0; s < 4; ++s) {
            z(s) = t.z[i][s];
        }
        const Eigen::Matrix4d S = H * P * H.transpose() + R;
        const Eigen::Matrix<double, 3, 4> K = P * H.transpose() * S.inverse();
        x += K * (z - H * x);
        const Eigen::Matrix3d I_KH = Eigen::Matrix3d::Identity() - K * H;
        P = I_KH * P * I_KH.transpose() + K * R * K.transpose();
        out.push_back({x(0), x(1), x(2)});
    }
    return out;
}

struct Fixed {
    std::vector<std::array<double, 3>> x;
    uint32_t rejected = 0;
    std::array<double, 3> q_end{};
    std::vector<std::array<double, 6>> learnt; /* per row: q_x̄, q_t (mm²/s), R A..D (mm²) */
    int falls[2] = {0, 0};                     /* the fall test's alarms, x̄ and slopes */
};

Fixed run_fixed(const Scenario &sc, const Trace &t, bool automatic) {
    static struct kalman_state kf;
    struct kalman_config cfg = {};
    cfg.process_noise_mm2[0] = automatic ? 0 : (fix_q32_t)std::llround(sc.qd * kPeriod * kQ32);
    cfg.process_noise_mm2[1] = automatic ? 0 : (fix_q32_t)std::llround(sc.qt * kPeriod * kQ32);
    cfg.process_noise_mm2[2] = cfg.process_noise_mm2[1];
    for (int s = 0; s < 4; ++s) {
        const double r = automatic ? 4.0 : sc.sigma[s] * sc.sigma[s] + 1.0 / 12.0;
        cfg.initial_noise_mm2[s] = (fix_q32_t)std::llround(r * kQ32);
    }
    cfg.gate_sigmas_q8 = 5u * 256u;
    cfg.gate_floor_mm = 3;
    cfg.warmup_rows = 5;
    cfg.noise_shift = 2;
    cfg.process_noise_auto = automatic;
    assert_int_equal(kalman_init(&kf, &cfg), KALMAN_OK);
    Fixed f;
    for (int i = 0; i < kRows; ++i) {
        if (!automatic && i == kRows / 2 && sc.qt_after != sc.qt) {
            /* the reading-for-reading check runs the true q: reconfigured at the change,
             * the state kept (only the Q entries differ) */
            kf.cfg.process_noise_mm2[1] = (fix_q32_t)std::llround(sc.qt_after * kPeriod * kQ32);
            kf.cfg.process_noise_mm2[2] = kf.cfg.process_noise_mm2[1];
        }
        struct kalman_rows rows;
        const uint16_t n_before[2] = {kf.cov.n_q[0][0], kf.cov.n_q[0][1]};
        kalman_push_row(&kf, t.z[i].data(), 0x0Fu, &rows);
        for (int g = 0; g < 2; ++g) {
            if (kf.cov.n_q[0][g] < n_before[g]) {
                f.falls[g]++;
                if (getenv("REF_TRACKING_LEVELS") != nullptr) {
                    std::printf("row %d: group %d forgot (a fall of q)\n", i, g);
                }
            }
        }
        for (unsigned r = 0; r < rows.count; ++r) {
            f.rejected += (uint32_t)__builtin_popcount(rows.rejected[r]);
        }
        f.x.push_back({(double)kf.x[0] / kQ32, (double)kf.x[1] / kQ32, (double)kf.x[2] / kQ32});
        fix_q32_t qn[3];
        kalman_process_noise(&kf, qn);
        if (automatic && getenv("REF_TRACKING_LEVELS") != nullptr && (i + 1) % 250 == 0) {
            std::printf("%5d q_t %.3g:", i + 1, (double)qn[1] / kQ32 / kPeriod);
            for (unsigned l = 0; l < KALMAN_ADAPT_LEVELS; ++l) {
                std::printf("  L%u n %3u %.3g", l, kf.cov.n_q[l][1],
                            kf.cov.mean_q[l][1] / 16777216.0 / kPeriod);
            }
            std::printf("\n");
        }
        f.learnt.push_back({(double)qn[0] / kQ32 / kPeriod, (double)qn[1] / kQ32 / kPeriod,
                            (double)kf.r[0] / kQ32, (double)kf.r[1] / kQ32, (double)kf.r[2] / kQ32,
                            (double)kf.r[3] / kQ32});
    }
    if (getenv("REF_TRACKING_LEVELS") != nullptr) {
        for (unsigned l = 0; l < KALMAN_ADAPT_LEVELS; ++l) {
            std::printf("level %u n %u mean q_x̄ %.4g q_t %.4g\n", l, kf.cov.n_q[l][1],
                        kf.cov.mean_q[l][0] / 16777216.0 / kPeriod,
                        kf.cov.mean_q[l][1] / 16777216.0 / kPeriod);
        }
    }
    fix_q32_t q[3];
    kalman_process_noise(&kf, q);
    for (int j = 0; j < 3; ++j) {
        f.q_end[j] = (double)q[j] / kQ32 / kPeriod;
    }
    return f;
}

double rms_angle(const std::vector<std::array<double, 3>> &x, const Trace &t, int axis, int from,
                 int to) {
    double sum = 0;
    for (int i = from; i < to; ++i) {
        const double e = std::atan(x[i][axis] / kArm) - std::atan(t.truth[i][axis] / kArm);
        sum += e * e;
    }
    return std::sqrt(sum / (to - from)) * 180.0 / kPi;
}

void test_reading_for_reading(void **state) {
    (void)state;
    for (const Scenario &sc : kScenarios) {
        const Trace t = make_trace(sc, 17);
        const auto opt = optimal(sc, t);
        const Fixed f = run_fixed(sc, t, false);
        assert_int_equal(f.rejected, 0);
        double worst = 0;
        for (int i = 10; i < kRows; ++i) {
            for (int j = 0; j < 3; ++j) {
                worst = std::fmax(worst, std::fabs(f.x[i][j] - opt[i][j]));
            }
        }
        print_message("%-24s fixed vs double, worst |dx| %.2e mm\n", sc.name, worst);
        assert_true(worst < 1e-2);
    }
}

void test_at_the_optimum(void **state) {
    (void)state;
    print_message(
        "| scenario | RMS α optimal (°) | α true q | α auto | RMS β optimal (°) | β true q "
        "| β auto | auto q_x̄, q_t at the end (mm²/s) |\n");
    print_message("| --- | ---: | ---: | ---: | ---: | ---: | ---: | --- |\n");
    for (const Scenario &sc : kScenarios) {
        double worst_true = 0, worst_auto = 0;
        double opt_rms[2] = {0, 0}, r_true[2] = {0, 0}, r_auto[2] = {0, 0};
        std::array<double, 3> q_end{};
        for (uint64_t seed = 1; seed <= 3; ++seed) {
            const Trace t = make_trace(sc, seed);
            const auto opt = optimal(sc, t);
            const Fixed ft = run_fixed(sc, t, false);
            const Fixed fa = run_fixed(sc, t, true);
            q_end = fa.q_end;
            for (int axis = 1; axis <= 2; ++axis) {
                const double o = rms_angle(opt, t, axis, kBurn, kRows);
                opt_rms[axis - 1] += o / 3;
                r_true[axis - 1] += rms_angle(ft.x, t, axis, kBurn, kRows) / o / 3;
                r_auto[axis - 1] += rms_angle(fa.x, t, axis, kBurn, kRows) / o / 3;
            }
        }
        for (int a = 0; a < 2; ++a) {
            worst_true = std::fmax(worst_true, r_true[a]);
            worst_auto = std::fmax(worst_auto, r_auto[a]);
        }
        print_message("| %s | %.4f | %.3f | %.3f | %.4f | %.3f | %.3f | %.3g, %.3g (true %.3g, "
                      "%.3g) |\n",
                      sc.name, opt_rms[0], r_true[0], r_auto[0], opt_rms[1], r_true[1], r_auto[1],
                      q_end[0], q_end[1], sc.qd, sc.qt);
        assert_true(worst_true <= 1.05); /* the goals */
        assert_true(worst_auto <= 1.10);
    }
}

void test_auto_converges_after_a_q_change(void **state) {
    (void)state;
    const Trace t = make_trace(kChange, 5);
    const auto opt = optimal(kChange, t);
    const Fixed fa = run_fixed(kChange, t, true);
    for (int axis = 1; axis <= 2; ++axis) {
        /* from 1000 rows after the change (20 s; the averages' memory is 512 rows) */
        const int from = kRows / 2 + 1000;
        const double ratio =
            rms_angle(fa.x, t, axis, from, kRows) / rms_angle(opt, t, axis, from, kRows);
        print_message("q change: axis %d auto/optimal %.3f after the change; learned q_t %.3g "
                      "(true %.3g)\n",
                      axis, ratio, fa.q_end[1], kChange.qt_after);
        assert_true(ratio <= 1.10);
    }
    /* the learned q_t followed the change (x40) to within a factor 2 */
    assert_true(fa.q_end[1] > kChange.qt_after / 2 && fa.q_end[1] < kChange.qt_after * 2);
}

/* The sweep: q_t over two decades, q_x̄ over two, σ 1 to 7 mm, plus one sensor
 * three times noisier and the approach; auto/optimal and true-q/optimal per scenario, the
 * mean over seeds [from, to] of each axis' ratio. Seeds 1-5 tuned the learning; 6-15 are
 * held out. Returns the worst auto ratio (α or β, mean over the seeds). */
std::vector<Scenario> sweep_scenarios(bool full, const std::vector<double> &qts_only = {}) {
    static const double qts_full[] = {0.01, 0.03, 0.1, 0.3, 1.0};
    static const double qts_short[] = {0.01, 0.1, 1.0};
    static const double qds[] = {0.5, 5.0, 50.0};
    static const double sigmas_full[] = {1.0, 3.0, 7.0};
    static const double sigmas_short[] = {1.0, 7.0};
    std::vector<Scenario> out;
    std::vector<double> qts = full ? std::vector<double>(qts_full, qts_full + 5)
                                   : std::vector<double>(qts_short, qts_short + 3);
    if (!qts_only.empty()) {
        qts = qts_only;
    }
    for (double qt : qts) {
        for (double qd : qds) {
            for (double sg : full ? std::vector<double>(sigmas_full, sigmas_full + 3)
                                  : std::vector<double>(sigmas_short, sigmas_short + 2)) {
                out.push_back({"walk", qd, qt, qt, {sg, sg, sg, sg}, false});
            }
        }
        out.push_back({"C 3x noisier", 2.0, qt, qt, {2.0, 2.0, 6.0, 2.0}, false});
        out.push_back({"approach", 4.0, qt, qt, {3.0, 3.0, 3.0, 3.0}, true});
    }
    return out;
}

double sweep(const std::vector<Scenario> &scs, uint64_t from, uint64_t to, double *worst_true) {
    print_message("seeds %llu-%llu; ratios RMS/RMS(optimal), mean over the seeds (worst seed)\n",
                  (unsigned long long)from, (unsigned long long)to);
    print_message(
        "| scenario | q_x̄ | q_t | σ (mm) | RMS α opt (°) | α true q | α auto | β true q | "
        "β auto | auto q_x̄, q_t at the end |\n");
    print_message("| --- | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | --- |\n");
    double worst_auto = 0;
    *worst_true = 0;
    for (const Scenario &sc : scs) {
        const double n = (double)(to - from + 1);
        double opt_a = 0, rt[2] = {0, 0}, ra[2] = {0, 0}, wa = 0, qx = 0, qt = 0;
        for (uint64_t seed = from; seed <= to; ++seed) {
            const Trace t = make_trace(sc, seed * 7919u + 11u);
            const auto opt = optimal(sc, t);
            const Fixed ft = run_fixed(sc, t, false);
            const Fixed fa = run_fixed(sc, t, true);
            qx += fa.q_end[0] / n;
            qt += fa.q_end[1] / n;
            for (int axis = 1; axis <= 2; ++axis) {
                const double o = rms_angle(opt, t, axis, kBurn, kRows);
                if (axis == 1) {
                    opt_a += o / n;
                }
                rt[axis - 1] += rms_angle(ft.x, t, axis, kBurn, kRows) / o / n;
                const double a = rms_angle(fa.x, t, axis, kBurn, kRows) / o;
                ra[axis - 1] += a / n;
                wa = std::fmax(wa, a);
            }
        }
        char sig[64];
        std::snprintf(sig, sizeof sig, "%.3g/%.3g/%.3g/%.3g", sc.sigma[0], sc.sigma[1], sc.sigma[2],
                      sc.sigma[3]);
        print_message(
            "| %s | %g | %g | %s | %.4f | %.3f | %.3f | %.3f | %.3f (%.2f) | %.3g, %.3g |\n",
            sc.name, sc.qd, sc.qt, sig, opt_a, rt[0], ra[0], rt[1], ra[1], wa, qx, qt);
        worst_auto = std::fmax(worst_auto, std::fmax(ra[0], ra[1]));
        *worst_true = std::fmax(*worst_true, std::fmax(rt[0], rt[1]));
    }
    print_message("worst mean ratio: true q %.3f, auto %.3f\n", *worst_true, worst_auto);
    return worst_auto;
}

/* The held-out sweep as a test (seeds 6-15, never used in tuning): q_t over two decades,
 * q_x̄ over two, σ 1 and 7 mm, one sensor 3x noisier, the approach. The bounds met there
 * (docs/explanation/accuracy.md): 1.07 (the goal 1.10) but for the slowest tilt at the
 * noisiest sensors (q_t 0.01 mm²/s, σ 7 mm on all four: 1.12 measured): 1.13 there. With the
 * true q: 1.05. */
void test_auto_sweep_held_out(void **state) {
    (void)state;
    std::vector<Scenario> scs;
    for (const Scenario &sc : sweep_scenarios(false)) {
        if (sc.qd != 5.0) {
            scs.push_back(sc);
        }
    }
    for (const Scenario &sc : scs) {
        double wt = 0;
        const double wa = sweep({sc}, 6, 15, &wt);
        const double sigma_min =
            std::fmin(std::fmin(sc.sigma[0], sc.sigma[1]), std::fmin(sc.sigma[2], sc.sigma[3]));
        const double bound = sc.qt <= 0.01 && sigma_min >= 7.0 ? 1.13 : 1.07;
        assert_true(wt <= 1.05);
        assert_true(wa <= bound);
    }
}

/* A step in q halfway, up and down two decades (q_t 0.01 <-> 1 mm²/s, σ 3 mm), scored from
 * 1 000 rows after the step: auto follows a rise within 1.10 (1.05 measured); a fall its
 * levels' test for a fall detects some 500 to 800 rows after it (kalman_adapt.c), and
 * 1 000 rows after the step the learning has not fully caught up: 1.43 measured (2.10
 * without the test), bounded at 1.5. */
/* auto/optimal after the step (mean over seeds [from, to] and both axes; *worst: the worst
 * seed and axis) for the rise (up) or the fall */
double step_ratio(bool up, uint64_t from, uint64_t to, double *worst) {
    const Scenario sc = up ? Scenario{"q_t 0.01 -> 1", 2.0, 0.01, 1.0, {3.0, 3.0, 3.0, 3.0}, false}
                           : Scenario{"q_t 1 -> 0.01", 2.0, 1.0, 0.01, {3.0, 3.0, 3.0, 3.0}, false};
    double mean = 0;
    *worst = 0;
    for (uint64_t seed = from; seed <= to; ++seed) {
        const Trace t = make_trace(sc, seed * 7919u + 11u);
        const auto opt = optimal(sc, t);
        const Fixed fa = run_fixed(sc, t, true);
        const int after = kRows / 2 + 1000;
        for (int axis = 1; axis <= 2; ++axis) {
            const double r =
                rms_angle(fa.x, t, axis, after, kRows) / rms_angle(opt, t, axis, after, kRows);
            *worst = std::fmax(*worst, r);
            mean += r / (2.0 * (double)(to - from + 1));
        }
    }
    print_message("%s: auto/optimal after the step %.3f (worst seed %.3f)\n", sc.name, mean,
                  *worst);
    return mean;
}

void step_figures(uint64_t from, uint64_t to) {
    double worst = 0;
    (void)step_ratio(true, from, to, &worst);
    (void)step_ratio(false, from, to, &worst);
}

void test_auto_follows_a_step(void **state) {
    (void)state;
    double worst = 0;
    assert_true(step_ratio(true, 6, 15, &worst) <= 1.10);
    assert_true(step_ratio(false, 6, 15, &worst) <= 1.5);
}

/* ref_tracking --trace QD QT SA SB SC SD SEED [ROWS [QT_AFTER]]: one run of `auto` (q_t
 * QT_AFTER from the middle on), every 250 rows the
 * learnt q and R and auto/optimal (the MSE ratio over those rows, α and β). */
void trace(const Scenario &sc, uint64_t seed) {
    const Trace t = make_trace(sc, seed * 7919u + 11u);
    const auto opt = optimal(sc, t);
    const Fixed fa = run_fixed(sc, t, true);
    std::printf("row | q_x̄ | q_t | R A B C D | MSE auto/opt α β (these rows)\n");
    for (int i = 0; i + 250 <= kRows; i += 250) {
        const auto &l = fa.learnt[i + 249];
        double ra[2];
        for (int axis = 1; axis <= 2; ++axis) {
            const double a = rms_angle(fa.x, t, axis, i, i + 250);
            const double o = rms_angle(opt, t, axis, i, i + 250);
            ra[axis - 1] = a * a / (o * o);
        }
        std::printf("%5d | %.3g | %.3g | %.3g %.3g %.3g %.3g | %.2f %.2f\n", i + 250, l[0], l[1],
                    l[2], l[3], l[4], l[5], ra[0], ra[1]);
    }
    double ra[2];
    for (int axis = 1; axis <= 2; ++axis) {
        ra[axis - 1] =
            rms_angle(fa.x, t, axis, kBurn, kRows) / rms_angle(opt, t, axis, kBurn, kRows);
    }
    std::printf("falls detected: x̄ %d, slopes %d\n", fa.falls[0], fa.falls[1]);
    std::printf("RMS auto/opt from row %d: %.3f %.3f", kBurn, ra[0], ra[1]);
    for (int from : {1500, kRows / 2}) {
        for (int axis = 1; axis <= 2; ++axis) {
            ra[axis - 1] =
                rms_angle(fa.x, t, axis, from, kRows) / rms_angle(opt, t, axis, from, kRows);
        }
        std::printf("; from row %d: %.3f %.3f", from, ra[0], ra[1]);
    }
    std::printf("\n");
}

} // namespace

int main(int argc, char **argv) {
    if ((argc >= 4) && std::string(argv[1]) == "--sweep") {
        /* the measurement (not a test): ref_tracking --sweep FIRST_SEED LAST_SEED [ROWS
         * [QT...]]: ROWS per run (6000), only these q_t (mm²/s; the sweep's five) */
        if (argc >= 5) {
            kRows = std::stoi(argv[4]);
        }
        std::vector<double> qts;
        for (int i = 5; i < argc; ++i) {
            qts.push_back(std::stod(argv[i]));
        }
        double wt = 0;
        sweep(sweep_scenarios(true, qts), std::stoull(argv[2]), std::stoull(argv[3]), &wt);
        return 0;
    }
    if (argc >= 9 && std::string(argv[1]) == "--trace") {
        if (argc >= 10) {
            kRows = std::stoi(argv[9]);
        }
        const Scenario sc = {
            "trace",
            std::stod(argv[2]),
            std::stod(argv[3]),
            argc >= 11 ? std::stod(argv[10]) : std::stod(argv[3]),
            {std::stod(argv[4]), std::stod(argv[5]), std::stod(argv[6]), std::stod(argv[7])},
            false};
        trace(sc, std::stoull(argv[8]));
        return 0;
    }
    if (argc >= 4 && std::string(argv[1]) == "--step") {
        step_figures(std::stoull(argv[2]), std::stoull(argv[3]));
        return 0;
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reading_for_reading),
        cmocka_unit_test(test_at_the_optimum),
        cmocka_unit_test(test_auto_converges_after_a_q_change),
        cmocka_unit_test(test_auto_sweep_held_out),
        cmocka_unit_test(test_auto_follows_a_step),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
