#pragma once
// The model table (SPEC §3–4): one row per CLI model, the single list that everything that
// differs by model is generated from. From it come the ModelKind enumerators (model_kind.h, in
// row order: ParaView's plugin stores them as integers, so append new rows at the end), the
// rows' data (kModelRows: names, help, arrays, population, …), the kernel variants AnyKernel,
// AnyKernel2D and AnyBivariateKernel (any_kernel.h, model_families.h) and the factories of the
// table (model_families.cpp). Nothing else switches on the model kind.
//
// A row is X(Enumerator, Kernel1D, Kernel2D, KernelBivariate, ModelRow fields …):
//   Kernel1D         its kernel with a 1D TF (SPEC §4);
//   Kernel2D         with a value × gradient TF2 (SPEC §9);
//   KernelBivariate  for bivariate fields (`--second`, SPEC §9): BivariateMean2DKernel for the
//                    mean field, Bivariate2DKernel (over the row's 1D kernel) for the others;
// NoKernel where the model has none for that TF kind. Each kernel type K has a factory
// `static K make(…)` (model_kernels.h, model_kernels_2d.h, model_kernels_bivariate.h) that
// builds it over a model for the row, reading only the row's fields; its header is included by
// any_kernel.h. The fields are ModelRow's (model_kind.h), designated and in declaration order;
// those left out take ModelRow's defaults. nsPerStep: a frame's cost at the reference speed
// (ns per pixel × ray step; 1D, 2D, bivariate; eval/experiment_plan.cpp says how it was
// measured; 0: not measured). A value that several rows share is a named constant beside
// ModelRow (kMeanAndStddev, kUniformCost, …), written once.
// clang-format off
#define UDVR_MODEL_ROWS(X)                                                                          \
    X(Mean, MeanKernel, Mean2DKernel, BivariateMean2DKernel,                                       \
      .name = "mean", .help = "the mean field",                                                    \
      .arrays = kArrayMean, .nsPerStep = {8.9, 15.0, 11.9})                                        \
    X(Uniform, UniformKernel, Uniform2DKernel, Bivariate2DKernel,                                  \
      .name = "uniform",                                                                           \
      .help = "box spline of the corners' uniforms, in its fast form (within 1e-3 of "            \
              "uniform-exact on real data; 2D by columns, docs/models.md)",                        \
      .arrays = kMeanAndStddev, .minMaxArrays = kMinAndMax, .nsPerStep = kUniformCost)             \
    X(Gaussian, GaussianKernel, Gaussian2DKernel, Bivariate2DKernel,                               \
      .name = "gaussian",                                                                          \
      .help = "N(sum w mu, sum w^2 sigma^2); with --tf2 its fast form (within 1e-3 of "            \
              "gaussian-exact)",                                                                   \
      .arrays = kMeanAndStddev, .nsPerStep = {39.0, 200.0, 1210.0})                                \
    X(GmmOrdered, GmmOrderedKernel, NoKernel, Bivariate2DKernel,                                   \
      .name = "gmm-ordered", .help = "the Gaussian mixture interpolated rank by rank",             \
      .arrays = kArrayGmm, .nsPerStep = {82.0, 0, 0})                                              \
    X(GmmMc, NoKernel, NoKernel, NoKernel,                                                         \
      .name = "gmm-mc",                                                                            \
      .help = "mean-field realizations of the mixture averaged in screen space (renders only: "    \
              "no distribution at a point)",                                                       \
      .arrays = kArrayGmm, .realizations = true, .nsPerStep = {7.95, 0, 0})                        \
    X(QuantileRange, QuantileRangeKernel, Quantile2DKernel, Bivariate2DKernel,                     \
      .name = "quantile-range", .help = "Eq. 4: each quantile uniform between its boundaries",     \
      .arrays = kArrayQuantiles, .population = {0, 1}, .labelShowsQ = true,                        \
      .nsPerStep = kQuantileRangeCost)                                                             \
    X(QuantileMean, QuantileMeanKernel, Quantile2DKernel, Bivariate2DKernel,                       \
      .name = "quantile-mean", .help = "Eq. 5: the TF at the quantiles' midpoints, density weights",\
      .arrays = kArrayQuantiles, .labelShowsQ = true,                                              \
      .quantileMeanWeights = QuantileMeanWeights::Density, .nsPerStep = kQuantileMeanCost)         \
    X(QuantileMeanMass, QuantileMeanKernel, Quantile2DKernel, Bivariate2DKernel,                   \
      .name = "quantile-mean-mass", .help = "Eq. 5 with equal weights 1/q",                        \
      .arrays = kArrayQuantiles, .labelShowsQ = true,                                              \
      .quantileMeanWeights = QuantileMeanWeights::Equal, .nsPerStep = kQuantileMeanCost)           \
    X(Iqr, QuantileRangeKernel, Quantile2DKernel, Bivariate2DKernel,                               \
      .name = "iqr", .help = "quantile-range over the iqr array's middle 50 %",                    \
      .arrays = kArrayIqr, .nsPerStep = {9.3, 16.0, 0})                                            \
    X(QuartileLower, QuantileRangeKernel, Quantile2DKernel, Bivariate2DKernel,                     \
      .name = "quartile-lower", .help = "quantile-range over the ranks [0, .25]",                  \
      .arrays = kArrayQuantiles, .population = {0, .25}, .nsPerStep = kQuantileRangeCost)          \
    X(QuartileMiddle, QuantileRangeKernel, Quantile2DKernel, Bivariate2DKernel,                    \
      .name = "quartile-middle", .help = "quantile-range over the ranks [.25, .75]",               \
      .arrays = kArrayQuantiles, .population = {.25, .75}, .nsPerStep = kQuantileRangeCost)        \
    X(QuartileUpper, QuantileRangeKernel, Quantile2DKernel, Bivariate2DKernel,                     \
      .name = "quartile-upper", .help = "quantile-range over the ranks [.75, 1]",                  \
      .arrays = kArrayQuantiles, .population = {.75, 1}, .nsPerStep = kQuantileRangeCost)          \
    X(Members, MembersKernel, NoKernel, Bivariate2DKernel,                                         \
      .name = "members", .help = "no model: an ensemble's TF averaged over its members",           \
      .arrays = kArrayMembers, .nsPerStep = {2.65, 0, 0})                                          \
    X(UniformFast, UniformKernel, Uniform2DKernel, Bivariate2DKernel,                              \
      .name = "uniform-fast", .help = "an alias of uniform (its name before issue 33)",            \
      .arrays = kMeanAndStddev, .minMaxArrays = kMinAndMax, .nsPerStep = kUniformCost)             \
    X(UniformExact, UniformKernel, Uniform2DKernel, Bivariate2DKernel,                             \
      .name = "uniform-exact", .help = "the uniform box spline exactly (uniform's reference)",     \
      .arrays = kMeanAndStddev, .minMaxArrays = kMinAndMax, .exactForm = true,                     \
      .nsPerStep = {925.0, 5000.0, 1160.0})                                                        \
    X(GaussianExact, GaussianKernel, Gaussian2DKernel, Bivariate2DKernel,                          \
      .name = "gaussian-exact",                                                                    \
      .help = "gaussian; with --tf2 the exact evaluation (gaussian's reference)",                  \
      .arrays = kMeanAndStddev, .exactForm = true, .nsPerStep = {39.0, 6690.0, 1210.0})
// clang-format on
