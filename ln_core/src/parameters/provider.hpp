// The provider side of parameters (ln/parameters_c.h): parameter blocks and
// the per-client server that answers ln/parameters/query, query_dict,
// override_dict_single and request_parameter_topic for all blocks of a
// client, as LN 2.9's providers do (same service names, texts, binary
// forms), so LN 2.9 clients, its manager GUI and ln_core clients can read
// and override them.
//
// State and threads. Each parameter keeps its input (as read at the last
// update), its output (the value in effect: the input, or the override as
// soon as it arrives) and the override, all row-major in the parameter's
// element type, under the server's one mutex. Service handlers run in the
// pool "parameter_service_pool" (4 threads, so a request waiting for a
// block's next step does not hold up the others) or, with
// LN_PARAMETER_SYNC_HANDLING=1, inside update(). Program callbacks
// (before_update in the handling thread, after_update in update()) run
// without the mutex held, so they may use the parameter API themselves.
//
// Lifetime. Blocks share their client's server; the last block to go
// releases the services. ln_deinit() of the client releases them earlier
// (client_closing()), after which blocks refuse updates.
#pragma once

#include <memory>
#include <string>

#include "ln/parameters_c.h"

namespace ln::paramcore {

class Server;
struct BlockState;

class Block {
 public:
  /// Throws clientlib::Failure.
  Block(ln_client clnt, const char* group_name, bool always_publish, const char* topic_name);
  ~Block();
  Block(const Block&) = delete;
  Block& operator=(const Block&) = delete;

  /// Throws clientlib::Failure (LNE_INVALID_PARAMETER) naming the problem.
  void register_signals(const ln_parameter_signal* signals, unsigned n_signals);
  /// Throws clientlib::Failure.
  void update(const void* const* inputs, void* const* outputs, bool only_inputs);
  const std::string& name() const;

 private:
  std::shared_ptr<Server> server_;
  std::shared_ptr<BlockState> state_;
};

/// ln_deinit() hook: releases the client's parameter services (and the
/// client-side look-up state, remote.hpp) while the client still exists.
void client_closing(ln_client clnt);

}  // namespace ln::paramcore
