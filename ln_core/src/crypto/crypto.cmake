# DSA signature helpers of ln.h (ln_dsa_dss1_*), on OpenSSL's libcrypto.
# include() this file from ln_core/CMakeLists.txt before client.cmake.
#
# Targets:
#   ln_crypto          static, position-independent library (links OpenSSL::Crypto)
#   crypto_unit_tests  GoogleTest unit tests (if BUILD_TESTING)
# Consumers include headers as "crypto/dsa.hpp".

find_package(OpenSSL 3.0 REQUIRED COMPONENTS Crypto)

set(LN_CRYPTO_SOURCE_DIR ${CMAKE_CURRENT_LIST_DIR})
get_filename_component(LN_CRYPTO_SRC_DIR ${CMAKE_CURRENT_LIST_DIR} DIRECTORY)
get_filename_component(LN_CRYPTO_ROOT_DIR ${LN_CRYPTO_SRC_DIR} DIRECTORY)

add_library(ln_crypto STATIC ${LN_CRYPTO_SOURCE_DIR}/dsa.cpp)
set_target_properties(ln_crypto PROPERTIES POSITION_INDEPENDENT_CODE ON CXX_VISIBILITY_PRESET hidden)
target_include_directories(ln_crypto PUBLIC $<BUILD_INTERFACE:${LN_CRYPTO_SRC_DIR}>
                                     PRIVATE ${LN_CRYPTO_ROOT_DIR}/include)
target_link_libraries(ln_crypto PUBLIC OpenSSL::Crypto)
ln_target_warnings(ln_crypto)

if(BUILD_TESTING)
  enable_testing()
  find_package(GTest REQUIRED)
  include(GoogleTest)
  add_executable(crypto_unit_tests ${LN_CRYPTO_SOURCE_DIR}/dsa_test.cpp)
  target_link_libraries(crypto_unit_tests PRIVATE ln_crypto GTest::gtest GTest::gtest_main)
  target_include_directories(crypto_unit_tests PRIVATE ${LN_CRYPTO_ROOT_DIR}/include)
  ln_target_warnings(crypto_unit_tests)
  gtest_discover_tests(crypto_unit_tests PROPERTIES TIMEOUT 60)
endif()
