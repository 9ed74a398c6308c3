// Marshalling the structs ln_generate writes, driven by the signature
// constants of the same header: the host layout computed from a signature
// must be the generated struct's, field for field.
#include <gtest/gtest.h>

#include <cstddef>
#include <cstring>
#include <string>
#include <tuple>
#include <vector>

#include "services/marshal.hpp"
#include "services_test_messages.h"

namespace ln::services {
namespace {

ServiceSignature compiled(const char* signature) {
  ServiceSignature s;
  const Status status = ServiceSignature::compile(signature, s);
  EXPECT_TRUE(status.ok()) << status.detail();
  return s;
}

TEST(GeneratedStructs, TimeServiceSignatureIsLN29s) {
  // Verbatim output of LN 2.9's ln_generate for tests/time_service.
  EXPECT_STREQ(TESTS_TIME_SERVICE_SIGNATURE,
               "uint64_t 8 1,int16_t 2 1,int16_t 2 4,uint32_t 4 1,int16_t* 2 1,[int32_t 4 1,uint8_t* 1 1,int32_t 4 1] "
               "8 1,[int32_t 4 1,uint8_t* 1 1,int32_t 4 1] 8 2,uint32_t 4 1,[int32_t 4 1,uint8_t* 1 1,int32_t 4 1]* 8 "
               "1|double 8 1,uint64_t 8 1");
}

TEST(GeneratedStructs, LayoutsMatchTheGeneratedStructs) {
  const ServiceSignature time = compiled(tests_time_service_signature);
  EXPECT_EQ(time.request().host_size(), sizeof(tests_time_service_t::req));
  EXPECT_EQ(time.response().host_size(), sizeof(tests_time_service_t::resp));
  EXPECT_EQ(time.response_offset(), offsetof(tests_time_service_t, resp));

  const ServiceSignature everything = compiled(svc_test_everything_signature);
  EXPECT_EQ(everything.request().host_size(), sizeof(svc_test_everything_t::req));
  EXPECT_EQ(everything.response().host_size(), sizeof(svc_test_everything_t::resp));
  EXPECT_EQ(everything.response_offset(), offsetof(svc_test_everything_t, resp));

  const ServiceSignature now = compiled(svc_test_now_signature);  // no request: resp comes first
  EXPECT_EQ(now.response_offset(), 0u);
  EXPECT_EQ(now.response().host_size(), sizeof(svc_test_now_t));
  const ServiceSignature fire = compiled(svc_test_fire_signature);
  EXPECT_EQ(fire.request().host_size(), sizeof(svc_test_fire_t));
  EXPECT_TRUE(fire.response().empty());
  EXPECT_TRUE(compiled(svc_test_ping_signature).request().empty());
}

TEST(GeneratedStructs, TimeServiceRoundTrip) {
  const ServiceSignature sig = compiled(tests_time_service_signature);
  int16_t shorts[3] = {-1, 2, -3};
  uint8_t pickles[4][5] = {{1, 2, 3, 4, 5}, {6}, {7, 8}, {9, 10, 11}};
  ln2_pyobject_t objects[2] = {{5, pickles[0], 1}, {0, nullptr, 0}};

  tests_time_service_t in{};
  in.req.count = 0x1122334455667788ull;
  in.req.short_single = -7;
  for (int i = 0; i < 4; ++i) in.req.shorts_static[i] = static_cast<int16_t>(100 + i);
  in.req.shorts_len = 3;
  in.req.shorts = shorts;
  in.req.obj_req_single = {1, pickles[1], 0};
  in.req.obj_req_static[0] = {2, pickles[2], 1};
  in.req.obj_req_static[1] = {3, pickles[3], 0};
  in.req.obj_req_len = 2;
  in.req.obj_req = objects;

  std::string wire;
  ASSERT_TRUE(flatten(sig.request(), &in, {}, wire).ok());
  tests_time_service_t out;
  std::memset(&out, 0xab, sizeof out);
  Arena arena;
  ASSERT_TRUE(unflatten(sig.request(), wire.data(), wire.size(), &out, {}, arena).ok());
  EXPECT_EQ(out.req.count, in.req.count);
  EXPECT_EQ(out.req.short_single, -7);
  EXPECT_EQ(out.req.shorts_static[3], 103);
  ASSERT_EQ(out.req.shorts_len, 3u);
  EXPECT_EQ(out.req.shorts[2], -3);
  EXPECT_EQ(out.req.obj_req_single.data_len, 1);
  EXPECT_EQ(out.req.obj_req_single.data[0], 6);
  EXPECT_EQ(out.req.obj_req_static[1].data_len, 3);
  EXPECT_EQ(out.req.obj_req_static[1].data[2], 11);
  ASSERT_EQ(out.req.obj_req_len, 2u);
  EXPECT_EQ(out.req.obj_req[0].data_len, 5);
  EXPECT_EQ(out.req.obj_req[0].data[4], 5);
  EXPECT_EQ(out.req.obj_req[0].is_pickle, 1);
  EXPECT_EQ(out.req.obj_req[1].data_len, 0);
  // The response part was not touched.
  const unsigned char* resp = reinterpret_cast<const unsigned char*>(&out.resp);
  for (std::size_t i = 0; i < sizeof out.resp; ++i) EXPECT_EQ(resp[i], 0xab);

  in.resp.time = 12.5;
  in.resp.count = 99;
  ASSERT_TRUE(flatten(sig.response(), &in.resp, {}, wire).ok());
  EXPECT_EQ(wire.size(), 16u);
  ASSERT_TRUE(unflatten(sig.response(), wire.data(), wire.size(), &out.resp, {}, arena).ok());
  EXPECT_EQ(out.resp.time, 12.5);
  EXPECT_EQ(out.resp.count, 99u);
}

TEST(GeneratedStructs, EverythingRoundTrip) {
  const ServiceSignature sig = compiled(svc_test_everything_signature);
  char text[] = "hello, service";
  double values[3] = {1.0, -2.0, 3.5};
  svc_test_point_t points[2] = {{1, 2, 3}, {4, 5, 6}};
  char name_a[] = "alpha";
  char name_b[] = "beta";
  uint16_t tags[3] = {7, 8, 9};
  svc_test_named_t items[2] = {{5, name_a, 1, 3, tags}, {4, name_b, 2, 0, nullptr}};
  svc_test_node_t grandchildren[1] = {{30, 0, nullptr}};
  svc_test_node_t children[2] = {{10, 1, grandchildren}, {20, 0, nullptr}};

  svc_test_everything_t in{};
  auto& r = in.req;
  r.a = -8;
  r.b = 200;
  r.c = -16000;
  r.d = 65000;
  r.e = -2000000000;
  r.f = 4000000000u;
  r.g = -9000000000000000000ll;
  r.h = 18000000000000000000ull;
  r.i = 0.25f;
  r.j = -1e300;
  r.k = 'Z';
  for (int i = 0; i < 16; ++i) r.matrix[i] = i * 1.5;
  r.origin = {0.5, 1.5, 2.5};
  r.corners[1] = {7, 8, 9};
  r.single = {4, name_b, 3, 2, tags + 1};
  r.pair[0] = {5, name_a, 4, 1, tags};
  r.text_len = static_cast<uint32_t>(std::strlen(text));
  r.text = text;
  r.values_len = 3;
  r.values = values;
  r.points_len = 2;
  r.points = points;
  r.items_len = 2;
  r.items = items;
  r.tree = {1, 2, children};

  for (bool swap : {false, true}) {
    SCOPED_TRACE(swap ? "swapped" : "native");
    ServiceSignature layout;
    ASSERT_TRUE(ServiceSignature::compile(svc_test_everything_signature, layout, swap).ok());
    std::string wire;
    ASSERT_TRUE(flatten(layout.request(), &in, {}, wire).ok());
    svc_test_everything_t out{};
    Arena arena;
    ASSERT_TRUE(unflatten(layout.request(), wire.data(), wire.size(), &out, {}, arena).ok());
    const auto& o = out.req;
    const auto scalars = [](const auto& x) {  // by value: the struct is packed
      return std::make_tuple(x.a, x.b, x.c, x.d, x.e, x.f, x.g, x.h, x.i, x.j);
    };
    EXPECT_EQ(scalars(o), scalars(r));
    EXPECT_EQ(o.k, 'Z');
    EXPECT_EQ(o.matrix[15], 22.5);
    EXPECT_EQ(o.origin.z, 2.5);
    EXPECT_EQ(o.corners[1].y, 8);
    EXPECT_EQ(std::string(o.single.name, o.single.name_len), "beta");
    EXPECT_EQ(o.single.tags[1], 9);
    EXPECT_EQ(std::string(o.pair[0].name, o.pair[0].name_len), "alpha");
    EXPECT_EQ(o.pair[1].name_len, 0u);
    EXPECT_EQ(std::string(o.text, o.text_len), "hello, service");
    EXPECT_EQ(o.values[2], 3.5);
    EXPECT_EQ(o.points[1].x, 4);
    ASSERT_EQ(o.items_len, 2u);
    EXPECT_EQ(o.items[0].tags[2], 9);
    EXPECT_EQ(std::string(o.items[1].name, o.items[1].name_len), "beta");
    EXPECT_EQ(o.tree.value, 1);
    ASSERT_EQ(o.tree.children_len, 2u);
    EXPECT_EQ(o.tree.children[0].children[0].value, 30);
    EXPECT_EQ(o.tree.children[1].value, 20);

    std::string again;
    ASSERT_TRUE(flatten(layout.request(), &out, {}, again).ok());
    EXPECT_EQ(again, wire);
  }
}

}  // namespace
}  // namespace ln::services
