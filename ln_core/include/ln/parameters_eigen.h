/// @file ln/parameters_eigen.h
/// @brief Eigen matrices and vectors as parameters (LN 2.9's API): a
///        port_description for every type derived from Eigen::EigenBase.
///
/// @code
///   #include <ln/parameters_eigen.h>
///   Eigen::Matrix3d gains = Eigen::Matrix3d::Identity(), gains_in_effect;
///   Eigen::Vector4f offsets = Eigen::Vector4f::Zero(), offsets_in_effect;
///   block.register_parameters(
///       ln::parameters::port_description<Eigen::Matrix3d>("gains", "", &gains, &gains_in_effect),
///       ln::parameters::port_description<Eigen::Vector4f>("offsets", "", &offsets, &offsets_in_effect));
/// @endcode
///
/// A column vector is a parameter of one dimension (as LN 2.9 shows it, a
/// list in Python), anything with more than one column a matrix of
/// rows x cols. The shape is taken when the description is made: a
/// dynamic-size matrix must have its final size by then and keep it (and
/// its storage) while the block lives. Column-major storage is what LN 2.9
/// supports; ln_core also takes row-major matrices (LN 2.9 asserts).
/// Callbacks receive a copy of the new value; what before_update leaves in
/// it is the value that takes effect, as for the other parameter types.
///
/// Include this header only where Eigen is available (Debian: libeigen3-dev);
/// ln/parameters.h does not need it.
#ifndef LN_PARAMETERS_EIGEN_H
#define LN_PARAMETERS_EIGEN_H

#include <Eigen/Dense>
#include <functional>
#include <type_traits>
#include <vector>

#include "parameters.h"

namespace ln {
namespace parameters {

template <typename T>
struct port_description<T, typename std::enable_if<std::is_base_of<Eigen::EigenBase<T>, T>::value, T>::type>
    : detail::port_description_shaped<T> {
  typedef typename T::Scalar scalar_type;

  port_description(std::string signal_name_, std::string signal_description_, T* input_, T* output_,
                   std::function<bool(T&)> before_update = std::function<bool(T&)>(),
                   std::function<void(T&)> after_update = std::function<void(T&)>())
      : detail::port_description_shaped<T>(std::move(signal_name_), std::move(signal_description_),
                                           _get_param_typeid<scalar_type>(), extents(*input_), input_->data(),
                                           output_ != nullptr ? output_->data() : nullptr,
                                           static_cast<bool>(T::IsRowMajor) && input_->cols() > 1, nullptr, nullptr) {
    // The core hands callbacks the value in the program's layout; a map of
    // the registered shape shows it to the callback as a T.
    const Eigen::Index rows = input_->rows(), cols = input_->cols();
    if (before_update)
      this->before_update_callback = [before_update, rows, cols](void* value) {
        Eigen::Map<T> in_place(static_cast<scalar_type*>(value), rows, cols);
        T copy = in_place;
        const bool accepted = before_update(copy);
        if (accepted && copy.rows() == rows && copy.cols() == cols) in_place = copy;  // as it left it
        return accepted;
      };
    if (after_update)
      this->after_update_callback = [after_update, rows, cols](void* value) {
        T copy = Eigen::Map<T>(static_cast<scalar_type*>(value), rows, cols);
        after_update(copy);
      };
  }

 private:
  // A column vector has one dimension (a list in Python, as in LN 2.9).
  static std::vector<uint32_t> extents(const T& m) {
    if (m.cols() > 1) return {static_cast<uint32_t>(m.rows()), static_cast<uint32_t>(m.cols())};
    return {static_cast<uint32_t>(m.rows())};
  }
};

}  // namespace parameters
}  // namespace ln

#endif  // LN_PARAMETERS_EIGEN_H
