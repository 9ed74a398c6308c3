// The LN C API (ln/ln.h) of the libln a links_and_nodes package uses: LN 2.9's
// or ln_core's, whichever the bridge imported. The data path calls it through
// these pointers, so it uses the very library -- and with ln_core the very
// client -- of the bridge's Python side. (LN 2.9's package loads its libln
// more than once, as separate copies: only the one its native module links
// holds its clients.)
#pragma once

#include <string>

#include "ln/ln.h"

namespace msg_mapping::bridge {

struct LnApi {
  std::string path;  ///< the library's file
  decltype(&ln_init_to_manager) init_to_manager = nullptr;
  decltype(&ln_deinit) deinit = nullptr;
  decltype(&ln_client_get_name) client_get_name = nullptr;
  decltype(&ln_subscribe_with_buffers) subscribe = nullptr;
  decltype(&ln_unsubscribe) unsubscribe = nullptr;
  decltype(&ln_read_timeout) read_timeout = nullptr;
  decltype(&ln_unblock) unblock = nullptr;
  decltype(&ln_publish_with_buffers) publish = nullptr;
  decltype(&ln_unpublish) unpublish = nullptr;
  decltype(&ln_write) write = nullptr;
  decltype(&ln_get_message_size) message_size = nullptr;
  decltype(&ln_format_error) format_error = nullptr;
  decltype(&ln_multi_waiter_init) multi_waiter_init = nullptr;
  decltype(&ln_multi_waiter_deinit) multi_waiter_deinit = nullptr;
  decltype(&ln_multi_waiter_add_port) multi_waiter_add = nullptr;
  decltype(&ln_multi_waiter_remove_port) multi_waiter_remove = nullptr;
  decltype(&ln_multi_waiter_wait) multi_waiter_wait = nullptr;
  decltype(&ln_multi_waiter_can_read) multi_waiter_can_read = nullptr;
  // ln_core's extensions (nullptr on LN 2.9): zero-copy reads with loss counts.
  decltype(&ln_read_borrow) read_borrow = nullptr;
  decltype(&ln_read_release) read_release = nullptr;

  /// The API of the libln that the loaded native module `module_file` (the
  /// package's _ln extension) links. Throws std::runtime_error when that
  /// module is not loaded or does not lead to an LN library.
  static const LnApi& of_module(const std::string& module_file);

  /// "what: LN's text for `ret`".
  std::string error(const std::string& what, int ret) const;
};

}  // namespace msg_mapping::bridge
