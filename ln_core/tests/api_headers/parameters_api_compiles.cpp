// Compile-only check of the parameters headers (never linked or run): LN
// 2.9's declarations in ln/parameters.h and ln/parameter_client.h with their
// exact types (typed member pointers), the enum values, the template forms
// LN 2.9 programs use, and ln/parameters_c.h's constants. Compiled as C++11,
// the standard LN 2.9 asks for.
#include <ln/parameter_client.h>
#include <ln/parameters.h>

#include <array>
#include <string>
#include <type_traits>
#include <vector>

namespace {

using namespace ln::parameters;

template <typename Expected, typename Actual>
constexpr bool same() {
  return std::is_same<Expected, Actual>::value;
}

// ---- LN 2.9's type ids and enums
static_assert(LN_DOUBLE == 0 && LN_SINGLE == 1 && LN_INT8 == 2 && LN_UINT8 == 3 && LN_INT16 == 4 && LN_UINT16 == 5 &&
                  LN_INT32 == 6 && LN_UINT32 == 7 && LN_BOOLEAN == 8 && LN_INT64 == 9 && LN_UINT64 == 10,
              "DataType values");
static_assert(static_cast<int>(LN_PARAM_DOUBLE) == static_cast<int>(LN_DOUBLE) &&
                  static_cast<int>(LN_PARAM_UINT64) == static_cast<int>(LN_UINT64) &&
                  static_cast<int>(LN_PARAM_BOOLEAN) == static_cast<int>(LN_BOOLEAN),
              "C ids are LN's");
static_assert(same<DataType, LnParameterTypes>(), "LnParameterTypes");
static_assert(static_cast<int>(ScalarKind::unknown) == 0 && static_cast<int>(ScalarKind::boolean) == 4, "ScalarKind");
static_assert(static_cast<int>(ValueSource::output) == 1 && static_cast<int>(MatrixLayout::column_major) == 1, "enums");

// ---- parameter_value and port descriptions
static_assert(same<std::vector<std::size_t>, decltype(parameter_value::shape)>(), "parameter_value::shape");
static_assert(same<std::vector<uint64_t>, decltype(parameter_value::input_integer)>(), "input_integer");
static_assert(same<std::vector<double>, decltype(parameter_value::output_float)>(), "output_float");
static_assert(same<DataType, decltype(parameter_value::element_data_type)>(), "element_data_type");
static_assert(same<std::function<bool(void*)>, decltype(port_description_void2::before_update_callback)>(),
              "port_description_void2::before_update_callback");
static_assert(same<uint32_t*, decltype(port_description_void2::dims)>(), "port_description_void2::dims");
static_assert(same<std::string, decltype(port_description<double>::signal_name)>(), "signal_name");
static_assert(same<uint32_t*, decltype(port_description<float[2][3]>::dims)>(), "array dims");
static_assert(std::is_constructible<port_description<int32_t>, std::string, std::string, int32_t*, int32_t*,
                                    std::function<bool(int32_t&)>, std::function<void(int32_t&)>>::value,
              "port_description(name, description, input, output, before, after)");
static_assert(
    std::is_constructible<port_description<double[4]>, std::string, std::string, double (*)[4], double (*)[4]>::value,
    "port_description of a C array");
static_assert(std::is_constructible<parameter_block, ln::client*, std::string>::value, "parameter_block(clnt, name)");
static_assert(std::is_constructible<parameter_block, ln::client*, std::string, bool, std::string>::value,
              "parameter_block(clnt, name, always_publish, topic_name)");
static_assert(std::is_default_constructible<parameter_proxy>::value, "parameter_proxy()");
static_assert(std::is_constructible<parameter_proxy, ln::client*, std::string, bool>::value,
              "parameter_proxy(clnt, prefix, strict)");

template <typename Expected>
void expect_type(Expected) {}
#define CHECK_METHOD(type, member) expect_type<type>(&member)

}  // namespace

void parameters_api_signatures();
void parameters_api_signatures() {
  using std::string;
  CHECK_METHOD(parameter_proxy(ln::client::*)(string, bool), ln::client::get_parameters);
  CHECK_METHOD(parameter_proxy(parameter_proxy::*)(string) const, parameter_proxy::get_parameters);
  CHECK_METHOD(bool(parameter_proxy::*)() const, parameter_proxy::strict_type_checks);
  CHECK_METHOD(void(parameter_proxy::*)(bool), parameter_proxy::set_strict_type_checks);
  CHECK_METHOD(string(parameter_proxy::*)(const string&) const, parameter_proxy::get_description);
  CHECK_METHOD(double(parameter_proxy::*)(const string&) const, parameter_proxy::get_input<double>);
  CHECK_METHOD(std::vector<float>(parameter_proxy::*)(const string&) const,
               parameter_proxy::get_output<std::vector<float>>);
  CHECK_METHOD(void(parameter_proxy::*)(const string&, const int&, bool) const, parameter_proxy::set_override<int>);
  CHECK_METHOD(void(parameter_proxy::*)(const string&, DataType, const void*, bool) const,
               parameter_proxy::set_override_from_data_scalar);
  CHECK_METHOD(void(parameter_proxy::*)(const string&, DataType, std::size_t, const void*, bool) const,
               parameter_proxy::set_override_from_data_vector);
  CHECK_METHOD(void(parameter_proxy::*)(const string&, DataType, std::size_t, std::size_t, const void*, MatrixLayout,
                                        std::size_t, bool) const,
               parameter_proxy::set_override_from_data_matrix);
  CHECK_METHOD(void(parameter_proxy::*)(const string&, DataType, ValueSource, void*) const,
               parameter_proxy::get_into_data_scalar);
  CHECK_METHOD(void(parameter_proxy::*)(const string&, DataType, ValueSource, std::size_t, void*) const,
               parameter_proxy::get_into_data_vector);
  CHECK_METHOD(void(parameter_proxy::*)(const string&, DataType, ValueSource, std::size_t, std::size_t, void*,
                                        MatrixLayout, std::size_t) const,
               parameter_proxy::get_into_data_matrix);
  CHECK_METHOD(void(parameter_proxy::*)(const string&, bool) const, parameter_proxy::reset_override);
  CHECK_METHOD(parameter_value(parameter_proxy::*)(const string&) const, parameter_proxy::get_internal_value);
  CHECK_METHOD(parameter_proxy::signal_proxy<double>(parameter_proxy::*)(const string&) const,
               parameter_proxy::get_signal<double>);
  CHECK_METHOD(double(parameter_proxy::signal_proxy<double>::*)() const,
               parameter_proxy::signal_proxy<double>::get_input);
  CHECK_METHOD(void(parameter_proxy::signal_proxy<double>::*)(const double&, bool) const,
               parameter_proxy::signal_proxy<double>::set_override);
  CHECK_METHOD(bool(parameter_block::*)(std::vector<port_description_void2>&), parameter_block::register_parameters);
  CHECK_METHOD(void(parameter_block::*)(), parameter_block::update);
  CHECK_METHOD(void(parameter_block::*)(const void**, void**, bool), parameter_block::update);
  CHECK_METHOD(uint32_t(*)(), _get_param_typeid<float>);

  // The forms LN 2.9 programs write.
  ln::client* clnt = nullptr;
  parameter_proxy p = clnt->get_parameters("group");
  (void)p.get_input<std::array<std::array<int16_t, 3>, 2>>("m");
  (void)p.get_output<std::vector<std::vector<double>>>("m");
  (void)p.get_output<bool>("flag");
  double matrix[2][3] = {};
  p.set_override("m", matrix);
  p.set_override("v", std::vector<bool>{true, false}, false);
  double gain = 0, gain_out = 0;
  float limits[2][3] = {}, limits_out[2][3] = {};
  parameter_block block(clnt, "group");
  block.register_parameters(port_description<double>("gain", "", &gain, &gain_out, [](double& v) { return v > 0; }),
                            port_description<float[2][3]>("limits", "", &limits, &limits_out));
}
