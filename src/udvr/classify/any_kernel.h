#pragma once
// Any model's kernel with a 1D TF (AnyKernel) and with a value × gradient TF2 (AnyKernel2D):
// std::variants of the kernel types that the model table's rows name (model_rows.h), each type
// once, in row order. Every kernel header is included here: a new model's kernel header is
// added to this list. A frame visits the variant once (withKernel); the ray loop then runs on
// the concrete kernel type.
#include <type_traits>
#include <variant>

#include "udvr/classify/model_kernels.h"
#include "udvr/classify/model_kernels_2d.h"
#include "udvr/classify/model_rows.h"

namespace udvr {

/// A row's kernel for a TF kind it has none for (model_rows.h).
struct NoKernel {};

namespace detail {
/// std::variant<Vs..., T> unless T is among Vs or is NoKernel.
template <class V, class T>
struct AddKernel;
template <class... Vs, class T>
struct AddKernel<std::variant<Vs...>, T> {
    using type = std::conditional_t<(std::is_same_v<T, Vs> || ...) || std::is_same_v<T, NoKernel>,
                                    std::variant<Vs...>, std::variant<Vs..., T>>;
};
/// The variant of the distinct kernel types Ts (NoKernel left out), in first-seen order.
template <class V, class... Ts>
struct KernelVariant {
    using type = V;
};
template <class V, class T, class... Ts>
struct KernelVariant<V, T, Ts...> : KernelVariant<typename AddKernel<V, T>::type, Ts...> {};
}  // namespace detail

#define UDVR_MODEL_KERNEL_1D(Enumerator, Kernel1D, Kernel2D, KernelBivariate, ...) , Kernel1D
#define UDVR_MODEL_KERNEL_2D(Enumerator, Kernel1D, Kernel2D, KernelBivariate, ...) , Kernel2D
/// Any model's kernel (SPEC §4).
using AnyKernel =
    typename detail::KernelVariant<std::variant<> UDVR_MODEL_ROWS(UDVR_MODEL_KERNEL_1D)>::type;
/// Any model's kernel with a 2D TF (SPEC §9).
using AnyKernel2D =
    typename detail::KernelVariant<std::variant<> UDVR_MODEL_ROWS(UDVR_MODEL_KERNEL_2D)>::type;
#undef UDVR_MODEL_KERNEL_1D
#undef UDVR_MODEL_KERNEL_2D

}  // namespace udvr
