/**
 * @file ln/parameters_c.h
 * @brief Parameters in C (ln_core extension): a program exposes values
 *        that other clients read and override while it runs.
 *
 * LN 2.9 has parameters in C++ (ln/parameters.h, ln/parameter_client.h) and
 * Python only; those are built on the functions here, which C programs may
 * use directly. Everything travels over LN's own services, so ln_core and
 * LN 2.9 providers and clients work with each other in any combination.
 *
 * Provider side: a parameter block groups parameters under a name
 * ("controller" -> "controller.gain"). The program registers each with a
 * pointer to its own value (input) and, optionally, to where the value in
 * effect is written (output), then calls ln_parameter_block_update() once
 * per control step: that reads every input and writes every output, which
 * is the input or, while another client overrides the parameter, the
 * override value. Overrides arrive at any time; they take effect at the
 * next update. A client's blocks share the services
 * ln.parameters.{query,query_dict,override_dict_single,request_topic}.<client name>
 * (group "parameter_services"), served by the thread pool
 * "parameter_service_pool", or inside ln_parameter_block_update() when the
 * environment has LN_PARAMETER_SYNC_HANDLING=1. LN_PARAMETER_PREFIX is put
 * in front of every block's name. LN_PARAMETER_DEBUG=1 reports overrides
 * and look-ups on stderr.
 *
 * Client side: ln_parameter_get() finds the client that provides a
 * parameter (by its full name) and reads it; ln_parameter_override()
 * overrides it, ln_parameter_override_text() with the value as text,
 * NULL resets it.
 *
 * Values are scalars, vectors or matrices of one element type (LN_PARAM_*).
 * Returns follow ln.h: >= 0 success, -LNE_* failure with the detail in
 * ln_get_error_message(). Unknown parameters fail with
 * -LNE_UNKNOWN_PARAMETER, values of the wrong shape or out of range with
 * -LNE_INVALID_PARAMETER, an override its provider refused with
 * -LNE_REQUEST_FAILED.
 */
#ifndef LN_PARAMETERS_C_H
#define LN_PARAMETERS_C_H

#include <stddef.h>
#include <stdint.h>

#include "ln.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Element types; the values are LN's type ids (ln::parameters::DataType). */
enum {
  LN_PARAM_DOUBLE = 0,
  LN_PARAM_SINGLE = 1, /**< float */
  LN_PARAM_INT8 = 2,
  LN_PARAM_UINT8 = 3,
  LN_PARAM_INT16 = 4,
  LN_PARAM_UINT16 = 5,
  LN_PARAM_INT32 = 6,
  LN_PARAM_UINT32 = 7,
  LN_PARAM_BOOLEAN = 8, /**< one byte, 0 or 1 */
  LN_PARAM_INT64 = 9,
  LN_PARAM_UINT64 = 10
};

/* ------------------------------------------------------------ provider */

typedef void* ln_parameter_block;

/** Checks an override before it is accepted; runs in the thread that
    handles the request. @return non-zero to accept @p new_value (in the
    parameter's type and layout), 0 to refuse (the overriding client gets
    an error). */
typedef int (*ln_parameter_check)(void* new_value, void* user_data);
/** Learns of an override taking effect; runs inside
    ln_parameter_block_update(), once per accepted override. */
typedef void (*ln_parameter_applied)(void* value, void* user_data);

/** One parameter of a block. */
typedef struct ln_parameter_signal {
  const char* name;                  /**< below the block's name; "a.b" makes a subgroup */
  const char* description;           /**< shown to users; may be NULL */
  unsigned int type;                 /**< LN_PARAM_* */
  unsigned int n_dims;               /**< 1 or 2 */
  const uint32_t* dims;              /**< n_dims sizes, each >= 1; {1} is a scalar */
  int row_major;                     /**< layout of 2-D values in input/output (0: column-major) */
  void* input;                       /**< the program's value; read by every update */
  void* output;                      /**< the value in effect, written by every update; may be NULL */
  ln_parameter_check before_update;  /**< may be NULL */
  ln_parameter_applied after_update; /**< may be NULL */
  void* user_data;                   /**< passed to both */
} ln_parameter_signal;

/** Creates a block named @p group_name (LN_PARAMETER_PREFIX + name).
    @param always_publish, topic_name publish the block's values on a topic
           (default name "<client name>.<block name>") at every update, not
           only while a client asked for it (ln/parameters/request_parameter_topic). */
LN_API int ln_parameter_block_init(ln_client clnt, ln_parameter_block* block, const char* group_name,
                                   int always_publish, const char* topic_name);
/** Registers the block's parameters; once per block. The values are
    copied from the inputs at once. Fails without registering anything if a
    name is empty or taken (also by another block of this client), a type
    or shape is invalid, or an input is NULL. */
LN_API int ln_parameter_block_register(ln_parameter_block block, const ln_parameter_signal* signals,
                                       unsigned int n_signals);
/** One step: reads the inputs, applies overrides, writes the outputs.
    @param inputs, outputs NULL: the pointers given at registration; else
           one pointer per parameter, in registration order (an output may
           be NULL).
    @param only_inputs non-zero: read the inputs but write no output. */
LN_API int ln_parameter_block_update(ln_parameter_block block, const void* const* inputs, void* const* outputs,
                                     int only_inputs);
/** The block's full name (with LN_PARAMETER_PREFIX); belongs to the block. */
LN_API const char* ln_parameter_block_get_name(ln_parameter_block block);
/** Ends the block; clients waiting for its next step get an error. Call it
    before ln_deinit() of its client (after that it only frees memory). */
LN_API int ln_parameter_block_deinit(ln_parameter_block* block);

/* -------------------------------------------------------------- client */

/** Flags of the client functions. */
#define LN_PARAMETER_WAIT_STEP 1    /**< override: return once the provider's next update applied it */
#define LN_PARAMETER_STRICT_TYPES 2 /**< floating and integer values do not convert into each other */
#define LN_PARAMETER_REDISCOVER 4   /**< ask every provider again instead of the remembered one */

/** One parameter as its provider reports it. The strings and buffers are
    allocated by the library; release them with ln_parameter_value_free(). */
typedef struct ln_parameter_value {
  char* name; /**< full name */
  char* description;
  char* data_type;     /**< LN's form: "double", "float3", "int16[2, 3]" */
  unsigned int type;   /**< LN_PARAM_* */
  unsigned int n_dims; /**< 0 scalar, 1 vector, 2 matrix (also 1 x n) */
  uint32_t dims[2];
  int override_enabled;
  void* input;   /**< the provider's own value, row-major */
  void* output;  /**< the value in effect, row-major */
  uint32_t size; /**< bytes of input (and of output) */
} ln_parameter_value;

/** Reads parameter @p name (full name, e.g. "controller.gain") from the
    client that provides it. @p flags: LN_PARAMETER_REDISCOVER.
    @p value is overwritten (free a previous one first). */
LN_API int ln_parameter_get(ln_client clnt, const char* name, int flags, ln_parameter_value* value);
/** Frees what ln_parameter_get() allocated and zeroes @p value. */
LN_API void ln_parameter_value_free(ln_parameter_value* value);
/** Converts the input (@p output 0) or output of @p value into @p n_elements
    elements of @p type, row-major. Values that do not fit @p type fail, as
    do floating/integer conversions with LN_PARAMETER_STRICT_TYPES. */
LN_API int ln_parameter_value_read(ln_client clnt, const ln_parameter_value* value, int output, unsigned int type,
                                   void* data, size_t n_elements, int flags);
/** Overrides parameter @p name with @p data: @p n_dims (0 scalar, 1, 2) and
    @p dims must be the parameter's, the elements (of @p type, row-major)
    are converted to its type and must fit. @p flags: LN_PARAMETER_WAIT_STEP,
    LN_PARAMETER_STRICT_TYPES, LN_PARAMETER_REDISCOVER. */
LN_API int ln_parameter_override(ln_client clnt, const char* name, unsigned int type, unsigned int n_dims,
                                 const uint32_t* dims, const void* data, int flags);
/** Overrides parameter @p name with a value written as a Python literal
    ("2.5", "[1, 2, 3]", "[[1, 0], [0, 1]]", "True"), or ends its override
    when @p text is NULL or "". @p flags: LN_PARAMETER_WAIT_STEP,
    LN_PARAMETER_REDISCOVER. */
LN_API int ln_parameter_override_text(ln_client clnt, const char* name, const char* text, int flags);

#ifdef __cplusplus
}
#endif

#endif /* LN_PARAMETERS_C_H */
