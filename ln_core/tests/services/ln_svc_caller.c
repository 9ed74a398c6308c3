/* A service caller written as for LN 2.9 (C API). Usage:
     ln_svc_caller SERVICE
   Waits for SERVICE, calls it with dynamic fields (1 MB blob) and checks the
   echo, then makes a call that times out and one more echo call. Prints
   "ok" and exits 0, or prints "error ..." and exits 1. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ln_messages.h"

static int fail(ln_client clnt, const char* what, int ret) {
  printf("error %s %d %s\n", what, ret, clnt != NULL ? ln_get_error_message(clnt) : "");
  fflush(stdout);
  return 1;
}

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  ln_client clnt = NULL;
  ln_service svc = NULL;
  int ret = ln_init(&clnt, "svc_caller", argc, argv);
  if (ret != 0) return fail(NULL, "init", ret);
  ret = ln_needs_provider(clnt, argv[1], 10.0);
  if (ret != 0) return fail(clnt, "needs_provider", ret);
  ret = ln_service_init(clnt, &svc, argv[1], "svc/test", svc_test_signature);
  if (ret != 0) return fail(clnt, "service_init", ret);

  const uint32_t blob_len = 1u << 20;
  uint8_t* blob = (uint8_t*)malloc(blob_len);
  for (uint32_t i = 0; i < blob_len; ++i) blob[i] = (uint8_t)(i * 31 + 7);
  char text[] = "across namespaces";
  svc_test_t data;
  memset(&data, 0, sizeof data);
  data.req.text_len = (uint32_t)strlen(text);
  data.req.text = text;
  data.req.blob_len = blob_len;
  data.req.blob = blob;
  ret = ln_service_call(svc, &data);
  if (ret != 0) return fail(clnt, "call", ret);
  if (data.resp.blob_len != blob_len || memcmp(data.resp.blob, blob, blob_len) != 0 ||
      data.resp.text_len != data.req.text_len || memcmp(data.resp.text, text, data.resp.text_len) != 0)
    return fail(clnt, "echo-mismatch", 0);

  memset(&data, 0, sizeof data);
  data.req.mode = 1; /* SLOW */
  data.req.delay_ms = 3000;
  ret = ln_service_call_with_timeout(svc, &data, 0.2);
  if (ret != -LNE_SVC_TIMEOUT) return fail(clnt, "timeout-expected", ret);

  memset(&data, 0, sizeof data);
  ret = ln_service_call(svc, &data);
  if (ret != 0) return fail(clnt, "call-after-timeout", ret);

  free(blob);
  ln_service_deinit(&svc);
  ln_deinit(&clnt);
  printf("ok\n");
  fflush(stdout);
  return 0;
}
