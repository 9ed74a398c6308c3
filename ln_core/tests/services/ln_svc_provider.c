/* A service provider written as for LN 2.9 (C API). Usage:
     ln_svc_provider SERVICE [pool N | group]
   Prints "ready" once registered, then serves svc/test until killed; "slow"
   when it starts handling a SLOW request (a test waits for that line).
   The request's mode selects the behaviour (see services_process_test.cpp). */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/uio.h>
#include <time.h>
#include <unistd.h>

#include "ln_messages.h"
#include "svc_provider_modes.h"

static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static int running, most_running;

static void sleep_ms(unsigned ms) {
  struct timespec t = {ms / 1000, (long)(ms % 1000) * 1000000L};
  nanosleep(&t, NULL);
}

static void echo(svc_test_t* data) {
  data->resp.text_len = data->req.text_len;
  data->resp.text = data->req.text;
  data->resp.blob_len = data->req.blob_len;
  data->resp.blob = data->req.blob;
  data->resp.items_len = data->req.items_len;
  data->resp.items = data->req.items;
  data->resp.count = data->req.items_len;
}

/* Responds with the request's text reversed and count 77, as the flat
   response fields of svc/test (text, blob, items, count) in an iovec list;
   `truncated` leaves out the count. */
static int respond_flat(ln_service_request req, const svc_test_t* data, int truncated) {
  char reversed[256];
  uint32_t text_len = data->req.text_len < sizeof reversed ? data->req.text_len : (uint32_t)sizeof reversed;
  for (uint32_t i = 0; i < text_len; ++i) reversed[i] = data->req.text[text_len - 1 - i];
  uint32_t no_elements = 0;
  uint32_t count = 77;
  struct iovec iov[5] = {{&text_len, sizeof text_len},
                         {reversed, text_len},
                         {&no_elements, sizeof no_elements},
                         {&no_elements, sizeof no_elements},
                         {&count, sizeof count}};
  return ln_service_request_respondv(req, iov, truncated ? 4 : 5);
}

struct later {
  ln_service_request req;
  svc_test_t data;
};

static void* answer_later(void* arg) {
  struct later* later = (struct later*)arg;
  sleep_ms(later->data.req.delay_ms);
  echo(&later->data);
  ln_service_request_respond(later->req);
  free(later);
  return NULL;
}

static int handle(ln_client clnt, ln_service_request req, void* user_data) {
  (void)clnt;
  (void)user_data;
  svc_test_t data;
  memset(&data, 0, sizeof data);
  if (ln_service_request_set_data(req, &data, svc_test_signature) != 0) return -LNE_SVC_REQ_SET_DATA_WRONG;
  switch (data.req.mode) {
    case SLOW:
      printf("slow\n");
      fflush(stdout);
      sleep_ms(data.req.delay_ms); /* the slow handler under test */
      break;
    case USER_ERROR:
      return data.req.error;
    case NO_RESPONSE:
      return 0;
    case ERROR_TEXT:
      return ln_service_request_respond_error(req, data.req.error, "the provider refuses");
    case LATER: {
      struct later* later = (struct later*)malloc(sizeof *later);
      later->req = req;
      if (ln_service_request_set_data(req, &later->data, svc_test_signature) != 0) return -1;
      pthread_t thread;
      pthread_create(&thread, NULL, answer_later, later);
      pthread_detach(thread);
      return -LNE_SVC_RESP_LATER;
    }
    case RESPONDV:
    case RESPONDV_INVALID:
      return respond_flat(req, &data, data.req.mode == RESPONDV_INVALID);
    case CONCURRENCY:
      pthread_mutex_lock(&lock);
      if (++running > most_running) most_running = running;
      pthread_mutex_unlock(&lock);
      sleep_ms(data.req.delay_ms);
      pthread_mutex_lock(&lock);
      --running;
      data.resp.count = (uint32_t)most_running;
      pthread_mutex_unlock(&lock);
      return ln_service_request_respond(req);
    default:
      break;
  }
  echo(&data);
  return ln_service_request_respond(req);
}

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  ln_client clnt;
  ln_service svc;
  int ret = ln_init(&clnt, "svc_provider", argc, argv);
  if (ret == 0) ret = ln_service_init(clnt, &svc, argv[1], "svc/test", svc_test_signature);
  if (ret == 0) ret = ln_service_provider_set_handler(svc, handle, NULL);
  const int pool = argc >= 4 && strcmp(argv[2], "pool") == 0;
  const int group = argc >= 3 && strcmp(argv[2], "group") == 0;
  if (ret == 0) ret = ln_service_provider_register_in_group(clnt, svc, pool || group ? "g" : NULL);
  if (ret == 0 && pool) ret = ln_set_max_threads(clnt, "p", (unsigned)atoi(argv[3]));
  if (ret == 0 && pool) ret = ln_handle_service_group_in_thread_pool(clnt, "g", "p");
  if (ret != 0) {
    printf("error %d %s\n", ret, ln_get_error_message(clnt));
    return 1;
  }
  printf("ready\n");
  fflush(stdout);
  for (;;) {
    if (pool)
      sleep(1);
    else if (ln_wait_and_handle_service_group_requests(clnt, group ? "g" : NULL, 1.0) < 0)
      return 1;
  }
}
