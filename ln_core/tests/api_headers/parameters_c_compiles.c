/* Compile-only check of ln/parameters_c.h as C11 (never linked or run): the
 * functions' types, the signal struct, the constants. */
#include <ln/parameters_c.h>

#define CHECK(ret, name, params) ret(*const check_##name) params = name

CHECK(int, ln_parameter_block_init, (ln_client, ln_parameter_block*, const char*, int, const char*));
CHECK(int, ln_parameter_block_register, (ln_parameter_block, const ln_parameter_signal*, unsigned int));
CHECK(int, ln_parameter_block_update, (ln_parameter_block, const void* const*, void* const*, int));
CHECK(const char*, ln_parameter_block_get_name, (ln_parameter_block));
CHECK(int, ln_parameter_block_deinit, (ln_parameter_block*));
CHECK(int, ln_parameter_get, (ln_client, const char*, int, ln_parameter_value*));
CHECK(void, ln_parameter_value_free, (ln_parameter_value*));
CHECK(int, ln_parameter_value_read, (ln_client, const ln_parameter_value*, int, unsigned int, void*, size_t, int));
CHECK(int, ln_parameter_override,
      (ln_client, const char*, unsigned int, unsigned int, const uint32_t*, const void*, int));
CHECK(int, ln_parameter_override_text, (ln_client, const char*, const char*, int));

_Static_assert(LN_PARAM_DOUBLE == 0 && LN_PARAM_SINGLE == 1 && LN_PARAM_BOOLEAN == 8 && LN_PARAM_UINT64 == 10,
               "LN's type ids");
_Static_assert((LN_PARAMETER_WAIT_STEP & LN_PARAMETER_STRICT_TYPES & LN_PARAMETER_REDISCOVER) == 0, "flag bits");

static int accept_positive(void* value, void* user_data) {
  (void)user_data;
  return *(double*)value > 0;
}

/* A provider and a client as a C program writes them. */
void parameters_c_program(ln_client clnt);
void parameters_c_program(ln_client clnt) {
  double gain = 1.5, gain_in_effect = 0;
  const uint32_t scalar[1] = {1};
  ln_parameter_signal signal = {"gain", "P gain",        LN_PARAM_DOUBLE, 1,    scalar, 1,
                                &gain,  &gain_in_effect, accept_positive, NULL, NULL};
  ln_parameter_block block;
  ln_parameter_value value;
  double read_back = 0;
  if (ln_parameter_block_init(clnt, &block, "controller", 0, "") != 0) return;
  ln_parameter_block_register(block, &signal, 1);
  ln_parameter_block_update(block, NULL, NULL, 0);
  if (ln_parameter_get(clnt, "controller.gain", 0, &value) == 0) {
    ln_parameter_value_read(clnt, &value, 1, LN_PARAM_DOUBLE, &read_back, 1, 0);
    ln_parameter_value_free(&value);
  }
  ln_parameter_override_text(clnt, "controller.gain", "2.5", LN_PARAMETER_WAIT_STEP);
  ln_parameter_block_deinit(&block);
}
