#include "udvr/classify/tf_table.h"

#include <gtest/gtest.h>

#include "udvr/classify/classify_test_util.h"

namespace udvr {
namespace {

void expectRgbaNear(const double v[4], const Rgba& r, double tol) {
    EXPECT_NEAR(v[0], r.r, tol);
    EXPECT_NEAR(v[1], r.g, tol);
    EXPECT_NEAR(v[2], r.b, tol);
    EXPECT_NEAR(v[3], r.a, tol);
}

TEST(TfTable, EvalMatchesTransferFunctionEverywhere) {
    CounterRng rng(7, 0, 0);
    for (int trial = 0; trial < 50; ++trial) {
        const TransferFunction1D tf = testing::randomTf(rng, -1.0, 2.0);
        const TfTableStorage st(tf, trial % 2 ? 4096 : 3);  // few buckets exercise the scan
        const TfTable& t = st.table();
        std::vector<double> xs = {-5.0, 7.0};
        for (double x : tf.colorX) xs.push_back(x);  // breakpoints and steps exactly
        for (double x : tf.opacityX) xs.push_back(x);
        for (int i = 0; i < 400; ++i) xs.push_back(-1.5 + 4.0 * rng.uniform());
        for (double x : xs) {
            double v[4];
            t.eval(x, v);
            expectRgbaNear(v, tf.classify(x), 2e-7);
        }
    }
}

TEST(TfTable, StepIsRightContinuous) {
    TransferFunction1D tf;
    tf.colorX = {0.0, 1.0};
    tf.color = {{1, 1, 1}, {1, 1, 1}};
    tf.opacityX = {0.0, 0.5, 0.5, 1.0};
    tf.opacity = {0.0, 0.2, 0.8, 0.8};
    const TfTableStorage st(tf);
    double v[4];
    st.table().eval(0.5, v);
    EXPECT_DOUBLE_EQ(v[3], 0.8);
    st.table().eval(std::nextafter(0.5, 0.0), v);
    EXPECT_NEAR(v[3], 0.2, 1e-12);
}

TEST(TfTable, MeanOverMatchesQuadrature) {
    CounterRng rng(8, 0, 0);
    for (int trial = 0; trial < 40; ++trial) {
        const TransferFunction1D tf = testing::randomTf(rng, 0.0, 1.0);
        const TfTableStorage st(tf);
        for (int i = 0; i < 20; ++i) {
            double lo = -0.3 + 1.6 * rng.uniform(), hi = -0.3 + 1.6 * rng.uniform();
            if (lo > hi) std::swap(lo, hi);
            // Midpoint rule on 20000 panels: error ≤ (jumps)·(panel width) ≈ 1e-4·(hi-lo)/… .
            const int n = 20000;
            double ref[4] = {0, 0, 0, 0};
            for (int k = 0; k < n; ++k) {
                const Rgba c = tf.classify(lo + (hi - lo) * (k + 0.5) / n);
                ref[0] += c.r / n, ref[1] += c.g / n, ref[2] += c.b / n, ref[3] += c.a / n;
            }
            double v[4];
            st.table().meanOver(lo, hi, v);
            for (int ch = 0; ch < 4; ++ch) EXPECT_NEAR(v[ch], ref[ch], 2e-4);
        }
    }
}

TEST(TfTable, TinyIntervalsAcrossBreakpointsStayExact) {
    TransferFunction1D tf;
    tf.colorX = {0.0, 1000.0};
    tf.color = {{0, 0, 0}, {1, 1, 1}};
    tf.opacityX = {0.0, 500.0, 500.0, 1000.0};
    tf.opacity = {0.0, 0.0, 1.0, 1.0};
    const TfTableStorage st(tf);
    const double eps = 1e-11;
    double v[4];
    st.table().meanOver(500.0 - eps, 500.0 + 3 * eps, v);  // 3/4 of it has α = 1
    EXPECT_NEAR(v[3], 0.75, 1e-6);
    st.table().meanOver(500.0, 500.0, v);  // zero width → TF(hi)
    EXPECT_DOUBLE_EQ(v[3], 1.0);
}

TEST(TfTable, ConstantAndSinglePointTf) {
    TransferFunction1D tf;
    tf.colorX = {3.0};
    tf.color = {{0.5, 0.25, 1.0}};
    tf.opacityX = {3.0};
    tf.opacity = {0.5};
    const TfTableStorage st(tf);
    double v[4];
    for (double x : {-1e9, 3.0, 1e9}) {
        st.table().eval(x, v);
        EXPECT_DOUBLE_EQ(v[0], 0.25);
        EXPECT_DOUBLE_EQ(v[3], 0.5);
    }
    st.table().meanOver(-10, 10, v);
    EXPECT_NEAR(v[2], 0.5, 1e-12);
}

}  // namespace
}  // namespace udvr
