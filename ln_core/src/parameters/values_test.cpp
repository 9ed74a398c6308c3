#include "parameters/values.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

namespace ln::paramcore {
namespace {

template <typename T>
std::vector<std::uint8_t> bytes_of(std::initializer_list<T> values) {
  std::vector<std::uint8_t> out(values.size() * sizeof(T));
  std::size_t i = 0;
  for (const T v : values) std::memcpy(out.data() + sizeof(T) * i++, &v, sizeof(T));
  return out;
}

template <typename T>
std::string display(ElementType type, std::vector<std::uint32_t> dims, std::initializer_list<T> values) {
  return format_value_for_display(type, Shape{std::move(dims)}, bytes_of<T>(values).data());
}

// What `text` becomes as an override of a parameter of `type`/`dims`: the
// value as override text, or "error: ...".
std::string override_of(const std::string& text, ElementType type, std::vector<std::uint32_t> dims) {
  Literal literal;
  std::string error;
  if (!parse_literal(text, literal, error)) return "syntax: " + error;
  const Shape shape{std::move(dims)};
  std::vector<std::uint8_t> value;
  error = literal_to_value(literal, type, shape, "p.x", value);
  if (!error.empty()) return "error: " + error;
  EXPECT_EQ(value.size(), shape.elements() * element_size(type));
  return format_value_for_override(type, shape, value.data());
}

TEST(Values, TypeIdsAndNamesAreLns) {
  const char* names[] = {"double", "float",  "int8", "uint8", "int16", "uint16",
                         "int32",  "uint32", "bool", "int64", "uint64"};
  for (unsigned id = 0; id < kElementTypeCount; ++id) {
    const ElementType type = *element_type_from_id(id);
    EXPECT_STREQ(element_type_name(type), names[id]);
    EXPECT_EQ(element_type_from_name(names[id]), type);
  }
  EXPECT_FALSE(element_type_from_id(11));
  EXPECT_FALSE(element_type_from_name("single"));
  EXPECT_EQ(element_size(ElementType::Boolean), 1u);
  EXPECT_EQ(element_size(ElementType::UInt64), 8u);
}

TEST(Values, ShapesShowAsLn29ShowsThem) {
  EXPECT_EQ((Shape{{1}}.form()), Shape::Form::Scalar);  // double, float[1]
  EXPECT_EQ((Shape{{4}}.form()), Shape::Form::List);
  EXPECT_EQ((Shape{{1, 1}}.form()), Shape::Form::List);    // double[1][1]: array([5.])
  EXPECT_EQ((Shape{{1, 3}}.form()), Shape::Form::List);    // double[1][3]: array([1., 2., 3.])
  EXPECT_EQ((Shape{{3, 1}}.form()), Shape::Form::Matrix);  // double[3][1]: array([[1.], [2.], [3.]])
  EXPECT_EQ((Shape{{2, 3}}.form()), Shape::Form::Matrix);
  const std::uint32_t dims[] = {2, 0, 3};
  EXPECT_EQ(check_dims(dims, 1), "");
  EXPECT_NE(check_dims(dims, 2), "");
  EXPECT_NE(check_dims(dims, 3), "");
  EXPECT_NE(check_dims(dims, 0), "");
}

TEST(Values, BinaryTypeStringsRoundTrip) {
  // As LN 2.9's ln/parameters/query writes them.
  EXPECT_EQ(binary_type_string(ElementType::Double, Shape{{1}}), "double");
  EXPECT_EQ(binary_type_string(ElementType::Double, Shape{{4}}), "double4");
  EXPECT_EQ(binary_type_string(ElementType::Int16, Shape{{2}}), "int162");
  EXPECT_EQ(binary_type_string(ElementType::Int16, Shape{{2, 2}}), "int16[2, 2]");
  EXPECT_EQ(binary_type_string(ElementType::Boolean, Shape{{2, 1}}), "bool[2, 1]");
  EXPECT_EQ(binary_type_string(ElementType::Double, Shape{{1, 3}}), "double[1, 3]");
  for (unsigned id = 0; id < kElementTypeCount; ++id) {
    for (const Shape& shape : std::vector<Shape>{Shape{{1}}, Shape{{7}}, Shape{{16}}, Shape{{1, 1}}, Shape{{3, 12}}}) {
      const ElementType type = *element_type_from_id(id);
      ElementType parsed_type = ElementType::Double;
      Shape parsed;
      ASSERT_TRUE(parse_binary_type_string(binary_type_string(type, shape), parsed_type, parsed));
      EXPECT_EQ(parsed_type, type);
      EXPECT_EQ(parsed, shape);
    }
  }
  ElementType t;
  Shape s;
  for (const char* bad : {"", "double0", "quad", "double[2]", "double[2, 0]", "double[a, 2]", "int8x", "double-1"})
    EXPECT_FALSE(parse_binary_type_string(bad, t, s)) << bad;
}

TEST(Values, DisplayTextIsLn29s) {
  // Texts observed in LN 2.9's query_dict answers.
  EXPECT_EQ(display<double>(ElementType::Double, {1}, {1.5}), "1.5");
  EXPECT_EQ(display<double>(ElementType::Double, {1}, {0.1}), "0.1");
  EXPECT_EQ(display<double>(ElementType::Double, {1}, {7}), "7.");
  EXPECT_EQ(display<double>(ElementType::Double, {1}, {-0.0005}), "-0.0005");
  EXPECT_EQ(display<float>(ElementType::Single, {1}, {0.1f}), "0.1000000014901161");
  EXPECT_EQ(display<float>(ElementType::Single, {1}, {0.3f}), "0.300000011920929");
  EXPECT_EQ(display<double>(ElementType::Double, {4}, {M_PI, 1e20, 123456789.125, 0}),
            "array([3.1415926535897931, 100000000000000000000., 123456789.125, 0.], dtype=double)");
  EXPECT_EQ(display<double>(ElementType::Double, {3}, {NAN, INFINITY, -INFINITY}),
            "array([nan, inf, -inf], dtype=double)");
  EXPECT_EQ(display<float>(ElementType::Single, {2}, {static_cast<float>(M_PI), 1e-7f}),
            "array([3.1415927410125732, 0.0000001000000012], dtype=float)");
  EXPECT_EQ(display<std::int8_t>(ElementType::Int8, {2}, {-128, 127}), "array([-128, 127], dtype=int8)");
  EXPECT_EQ(display<std::uint64_t>(ElementType::UInt64, {2}, {0, UINT64_MAX}),
            "array([0, 18446744073709551615], dtype=uint64)");
  EXPECT_EQ(display<std::int64_t>(ElementType::Int64, {1}, {INT64_MIN}), "-9223372036854775808");
  EXPECT_EQ(display<std::uint8_t>(ElementType::Boolean, {3}, {1, 0, 1}), "array([True, False, True], dtype=bool)");
  EXPECT_EQ(display<std::int16_t>(ElementType::Int16, {2, 2}, {1, -2, 3, -4}),
            "array([[1, -2], [3, -4]], dtype=int16)");
  EXPECT_EQ(display<std::uint8_t>(ElementType::Boolean, {2, 1}, {1, 0}), "array([[True], [False]], dtype=bool)");
  EXPECT_EQ(display<double>(ElementType::Double, {1, 3}, {1, 2, 3}), "array([1., 2., 3.], dtype=double)");
  EXPECT_EQ(display<double>(ElementType::Double, {1, 1}, {5}), "array([5.], dtype=double)");
  EXPECT_EQ(display<float>(ElementType::Single, {1}, {2.5f}), "2.5");
}

TEST(Values, DisplayTextIsExactWhereLn29LosesPrecision) {
  // LN 2.9 shows -1e-20 as "-0."; the text must read back as the value.
  EXPECT_EQ(display<double>(ElementType::Double, {1}, {-1e-20}), "-1e-20");
  EXPECT_EQ(format_element_exact(ElementType::Double, bytes_of<double>({1e16}).data()), "1e+16");
  EXPECT_EQ(format_element_exact(ElementType::Double, bytes_of<double>({123456789012345.0}).data()),
            "123456789012345.0");
  EXPECT_EQ(format_element_exact(ElementType::Double, bytes_of<double>({0.0001}).data()), "0.0001");
  EXPECT_EQ(format_element_exact(ElementType::Double, bytes_of<double>({-0.00001}).data()), "-1e-05");
  EXPECT_EQ(format_element_exact(ElementType::Double, bytes_of<double>({12.5}).data()), "12.5");
  EXPECT_EQ(format_element_exact(ElementType::Double, bytes_of<double>({0}).data()), "0.0");
  EXPECT_EQ(format_element_exact(ElementType::Double, bytes_of<double>({-0.0}).data()), "-0.0");
  EXPECT_EQ(format_element_exact(ElementType::Single, bytes_of<float>({0.1f}).data()), "0.1");
  EXPECT_EQ(display<float>(ElementType::Single, {1}, {1e-30f}), "1e-30");
  for (const double v : {1e-300, -4.9e-324, 1.0 / 3, 2.0 / 3 * 1e-5, 1e300, -0.0}) {
    const std::string text = display<double>(ElementType::Double, {1}, {v});
    EXPECT_EQ(std::strtod(text.c_str(), nullptr), v) << text;
  }
}

TEST(Values, OverridesAcceptWhatLn29Accepts) {
  EXPECT_EQ(override_of("2.5", ElementType::Double, {1}), "2.5");
  EXPECT_EQ(override_of("7", ElementType::Double, {1}), "7.0");
  EXPECT_EQ(override_of(" 3 ", ElementType::Double, {1}), "3.0");
  EXPECT_EQ(override_of("1e3", ElementType::Double, {1}), "1000.0");
  EXPECT_EQ(override_of("0x10", ElementType::Double, {1}), "16.0");
  EXPECT_EQ(override_of("nan", ElementType::Double, {1}), "nan");
  EXPECT_EQ(override_of("-inf", ElementType::Single, {1}), "-inf");
  EXPECT_EQ(override_of("0.3", ElementType::Single, {1}), "0.3");
  EXPECT_EQ(override_of("-2.7", ElementType::Int8, {1}), "-2");  // truncated, as LN 2.9
  EXPECT_EQ(override_of("18446744073709551615", ElementType::UInt64, {1}), "18446744073709551615");
  EXPECT_EQ(override_of("-9223372036854775808", ElementType::Int64, {1}), "-9223372036854775808");
  EXPECT_EQ(override_of("True", ElementType::Boolean, {1}), "True");
  EXPECT_EQ(override_of("2", ElementType::Boolean, {1}), "True");
  EXPECT_EQ(override_of("0.5", ElementType::Boolean, {1}), "False");
  EXPECT_EQ(override_of("array([1, 2, 3, 4])", ElementType::Double, {4}), "array([1.0, 2.0, 3.0, 4.0])");
  EXPECT_EQ(override_of("array([1., 2., 3., 4.], dtype=double)", ElementType::Double, {4}),
            "array([1.0, 2.0, 3.0, 4.0])");
  EXPECT_EQ(override_of("array([[1, 2], [3, 4]])", ElementType::Int16, {2, 2}), "array([[1, 2], [3, 4]])");
  EXPECT_EQ(override_of("array([False, True, False])", ElementType::Boolean, {3}), "array([False, True, False])");
  EXPECT_EQ(override_of("array([0, 1, 2])", ElementType::Boolean, {3}), "array([False, True, True])");
  EXPECT_EQ(override_of("array([7, 8, 9])", ElementType::Double, {1, 3}), "array([7.0, 8.0, 9.0])");
  EXPECT_EQ(override_of("array([4])", ElementType::Double, {1, 1}), "array([4.0])");
  EXPECT_EQ(override_of("array([[7], [8], [9]])", ElementType::Double, {3, 1}), "array([[7.0], [8.0], [9.0]])");
  EXPECT_EQ(override_of("4.5", ElementType::Single, {1}), "4.5");
}

TEST(Values, OverridesAcceptMoreThanLn29WhereItIsUnambiguous) {
  EXPECT_EQ(override_of("[5, 6, 7, 8]", ElementType::Double, {4}), "array([5.0, 6.0, 7.0, 8.0])");
  EXPECT_EQ(override_of("[[5, 6], [7, 8]]", ElementType::Int16, {2, 2}), "array([[5, 6], [7, 8]])");
  EXPECT_EQ(override_of("[1. 2. 3.]", ElementType::Double, {3}), "array([1.0, 2.0, 3.0])");  // numpy str()
  EXPECT_EQ(override_of("array([[7, 8, 9]])", ElementType::Double, {1, 3}), "array([7.0, 8.0, 9.0])");
  EXPECT_EQ(override_of("array([4.5])", ElementType::Single, {1}), "4.5");
  EXPECT_EQ(override_of("array(5.)", ElementType::Double, {1}), "5.0");
  EXPECT_EQ(override_of("np.float64(1.5)", ElementType::Double, {1}), "1.5");
  EXPECT_EQ(override_of("np.int8(-3)", ElementType::Int32, {1}), "-3");
  EXPECT_EQ(override_of("True", ElementType::UInt16, {1}), "1");  // LN 2.9: 0
  EXPECT_EQ(override_of("True", ElementType::Double, {1}), "1.0");
}

TEST(Values, OverridesRejectWhatLn29WouldCorrupt) {
  // LN 2.9 turns each of these silently into another value.
  EXPECT_NE(override_of("abc", ElementType::Double, {1}).find("'abc' is not a number"), std::string::npos);
  EXPECT_NE(override_of("300", ElementType::Int8, {1}).find("300 does not fit int8 (-128..127)"), std::string::npos);
  EXPECT_NE(override_of("-129", ElementType::Int8, {1}).find("does not fit"), std::string::npos);
  EXPECT_NE(override_of("-1", ElementType::UInt64, {1}).find("does not fit uint64"), std::string::npos);
  EXPECT_NE(override_of("1e30", ElementType::UInt64, {1}).find("does not fit"), std::string::npos);
  EXPECT_NE(override_of("9223372036854775808", ElementType::Int64, {1}).find("does not fit"), std::string::npos);
  EXPECT_NE(override_of("65536", ElementType::UInt16, {1}).find("does not fit"), std::string::npos);
  EXPECT_NE(override_of("1e40", ElementType::Single, {1}).find("does not fit float"), std::string::npos);
  EXPECT_NE(override_of("nan", ElementType::Int32, {1}).find("does not fit"), std::string::npos);
  EXPECT_NE(override_of("5.5abc", ElementType::Double, {1}).find("'5.5abc' is not a number"), std::string::npos);
  EXPECT_NE(override_of("5,6", ElementType::Double, {1}).find("syntax"), std::string::npos);
  EXPECT_NE(override_of("  ", ElementType::Double, {1}).find("syntax"), std::string::npos);
  EXPECT_NE(override_of("'5'", ElementType::Double, {1}).find("string"), std::string::npos);
}

TEST(Values, OverridesRejectWrongShapesNamingTheParameter) {
  const std::string scalar_as_list = override_of("array([1., 2.])", ElementType::Double, {1});
  EXPECT_NE(scalar_as_list.find("parameter 'p.x' (double) is a scalar"), std::string::npos) << scalar_as_list;
  EXPECT_NE(override_of("5", ElementType::Double, {4}).find("takes a list of 4 values, not a single value"),
            std::string::npos);
  EXPECT_NE(override_of("array([1,2,3])", ElementType::Double, {4}).find("takes 4 values, the list has 3"),
            std::string::npos);
  EXPECT_NE(override_of("array([1,2,3,4,5])", ElementType::Double, {4}).find("the list has 5"), std::string::npos);
  EXPECT_NE(override_of("array([[1,2],[3,4]])", ElementType::Double, {4}).find("list of rows"), std::string::npos);
  EXPECT_NE(override_of("array([1, 2, 3, 4])", ElementType::Int16, {2, 2}).find("flat list"), std::string::npos);
  EXPECT_NE(
      override_of("array([[1, 2], [3, 4], [5, 6]])", ElementType::Int16, {2, 2}).find("takes 2 rows, the value has 3"),
      std::string::npos);
  EXPECT_NE(override_of("array([[1, 2, 3], [3, 4, 5]])", ElementType::Int16, {2, 2}).find("row 0 has 3"),
            std::string::npos);
  EXPECT_NE(override_of("array([[1, 2], [3]])", ElementType::Int16, {2, 2}).find("row 1 has 1"), std::string::npos);
  EXPECT_NE(override_of("array([[1, 2], [3, 'x']])", ElementType::Int16, {2, 2}).find("string"), std::string::npos);
  EXPECT_NE(override_of("array([1, [2]])", ElementType::Double, {2}).find("element 1 is a list"), std::string::npos);
  EXPECT_NE(override_of("array([1,2,3,4)", ElementType::Double, {4}).find("syntax"), std::string::npos);
  EXPECT_NE(override_of("array([7, 8, 9])", ElementType::Double, {3, 1}).find("flat list"), std::string::npos);
}

TEST(Values, ExactOverrideTextReadsBackAsTheSameValue) {
  for (unsigned id = 0; id < kElementTypeCount; ++id) {
    const ElementType type = *element_type_from_id(id);
    const std::size_t size = element_size(type);
    // Extremes and awkward values of every type, written and read back.
    std::vector<Scalar> values = {Scalar::of_signed(0),         Scalar::of_signed(-1),
                                  Scalar::of_unsigned(1),       Scalar::of_float(0.1),
                                  Scalar::of_float(-1e-20),     Scalar::of_float(1.0 / 3),
                                  Scalar::of_signed(INT64_MIN), Scalar::of_unsigned(UINT64_MAX),
                                  Scalar::of_float(3.4e38),     Scalar::of_float(-INFINITY)};
    for (const Scalar& v : values) {
      std::uint8_t stored[8] = {};
      if (!store_element(type, v, stored).empty()) continue;  // does not fit this type
      const std::string text = format_element_exact(type, stored);
      Literal literal;
      std::string error;
      ASSERT_TRUE(parse_literal(text, literal, error)) << text;
      std::vector<std::uint8_t> back;
      ASSERT_EQ(literal_to_value(literal, type, Shape{{1}}, "p", back), "") << text;
      EXPECT_EQ(std::memcmp(back.data(), stored, size), 0) << element_type_name(type) << " " << text;
    }
  }
}

TEST(Values, LayoutsConvertBothWays) {
  const Shape shape{{2, 3}};
  const std::vector<std::uint8_t> row = bytes_of<std::int16_t>({1, 2, 3, 4, 5, 6});
  std::vector<std::uint8_t> column(row.size()), back(row.size());
  from_row_major(row.data(), column.data(), ElementType::Int16, shape, false);
  EXPECT_EQ(column, bytes_of<std::int16_t>({1, 4, 2, 5, 3, 6}));
  to_row_major(column.data(), back.data(), ElementType::Int16, shape, false);
  EXPECT_EQ(back, row);
  to_row_major(row.data(), back.data(), ElementType::Int16, shape, true);
  EXPECT_EQ(back, row);
}

}  // namespace
}  // namespace ln::paramcore
