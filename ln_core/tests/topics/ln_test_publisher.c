/* A publisher written as for LN 2.9, in C: publishes test/p64 packets with
   increasing sequence numbers.

   usage: ln_test_publisher [LN options] TOPIC COUNT PERIOD_US [wait] [linger]
     COUNT 0 publishes until killed; "wait" first waits (at most 10 s) until
     the topic has a subscriber; "linger" stays published after the last
     packet until the topic has no subscriber left (at most 10 s), so that
     a subscriber still setting up gets the packets. */
#include <ln/ln.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ln_messages.h"

int main(int argc, char** argv) {
  ln_client clnt = NULL;
  int ret = ln_init(&clnt, "c_publisher", argc, argv);
  if (ret != 0) {
    fprintf(stderr, "ln_init: %s\n", ln_format_error(ret));
    return 2;
  }
  unsigned int n_args = 0;
  char* args = NULL;
  ln_get_remaining_args(clnt, &n_args, &args);
  const char* arg[6] = {NULL, NULL, NULL, NULL, NULL, NULL};
  for (unsigned int i = 0; i < n_args && i < 6; ++i) {
    arg[i] = args;
    args += strlen(args) + 1;
  }
  if (n_args < 4) {
    fprintf(stderr, "usage: ln_test_publisher [LN options] TOPIC COUNT PERIOD_US [wait] [linger]\n");
    return 2;
  }
  const char* topic = arg[1];
  const unsigned long count = strtoul(arg[2], NULL, 10);
  const double period = strtod(arg[3], NULL) * 1e-6;

  ln_outport port = NULL;
  ret = ln_publish(clnt, topic, TEST_P64_MD_NAME, &port);
  if (ret != 0) {
    fprintf(stderr, "ln_publish: %s: %s\n", ln_format_error(ret), ln_get_error_message(clnt));
    return 2;
  }
  printf("publishing %s\n", topic);
  fflush(stdout);
  int wait = 0, linger = 0;
  for (unsigned int i = 4; i < n_args && i < 6; ++i) {
    if (strcmp(arg[i], "wait") == 0)
      wait = 1;
    else if (strcmp(arg[i], "linger") == 0)
      linger = 1;
  }
  if (wait) {
    const double deadline = ln_get_monotonic_time() + 10.0;
    while (ln_has_subscriber(port) <= 0 && ln_get_monotonic_time() < deadline) ln_sleep_seconds(0.001);
  }

  test_p64_t packet;
  memset(&packet, 0, sizeof packet);
  unsigned long seq;
  for (seq = 1; count == 0 || seq <= count; ++seq) {
    packet.seq = (uint32_t)seq;
    memset(packet.pad, (int)(seq & 0xff), sizeof packet.pad);
    ret = ln_write(port, &packet, sizeof packet, NULL);
    if (ret != 0) {
      fprintf(stderr, "ln_write: %s\n", ln_format_error(ret));
      return 1;
    }
    if (period > 0) ln_sleep_seconds(period);
  }
  printf("published %lu\n", seq - 1);
  fflush(stdout);
  if (linger) {
    const double deadline = ln_get_monotonic_time() + 10.0;
    while (ln_has_subscriber(port) > 0 && ln_get_monotonic_time() < deadline) ln_sleep_seconds(0.001);
  }
  ln_unpublish(&port);
  ln_deinit(&clnt);
  return 0;
}
