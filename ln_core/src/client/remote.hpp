// Topic data between hosts (ln_spec §1.2, §6.4; methods.hpp receive_address
// and subscribers_changed.remote). There are no daemons: the publisher's
// client sends every packet itself to each subscriber on another host, over
// UDP by default and over TCP for subscriptions that asked for reliable
// transport. The subscriber's client receives them and writes them into a
// private shared-memory ring of the subscription, from which the port reads
// exactly as from a local publisher's segment.
//
//   publisher host                              subscriber host
//   ShmWriter -> segment -> RemoteSender thread ---UDP/TCP---> RemoteReceiver
//                           (ShmReader, per remote subscription)  thread ->
//                                                      inbox ShmWriter -> InPort
//
// Wire format of one packet (little endian): u32 magic "LNT1", u64
// subscription_id, u64 sequence, f64 timestamp, u32 packet size, u32 offset
// of this fragment, then the fragment. UDP datagrams carry fragments of at
// most kMaxDatagramPayload bytes; TCP carries whole packets, each preceded
// by a u32 frame length. Payloads travel in host byte order (no conversion
// between hosts of different endianness).
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "client/net.hpp"
#include "transport/shm_ring.hpp"

namespace ln::clientlib {

class OutPort;

/// One remote subscriber of a topic, as subscribers_changed lists it.
struct RemoteTarget {
  std::int64_t subscription_id = 0;
  double rate = -1;
  bool reliable = false;
  std::string address;  ///< "IP:PORT"
  bool operator<(const RemoteTarget& other) const;
  /// Parses "subscription_id rate reliable IP:PORT"; false if malformed.
  static bool parse(const std::string& text, RemoteTarget& target);
};

/// Feeds one remote subscriber from the publisher's own segment, in a thread.
class RemoteSender {
 public:
  /// Starts the thread. `port` must outlive the sender (OutPort stops its
  /// senders before it dies).
  RemoteSender(OutPort& port, RemoteTarget target);
  ~RemoteSender();
  RemoteSender(const RemoteSender&) = delete;
  RemoteSender& operator=(const RemoteSender&) = delete;

 private:
  void run();
  bool attach(std::optional<std::uint64_t> resume_after);
  bool connect_target();
  bool send_packet(const void* data, std::uint32_t size, std::uint64_t sequence, double timestamp);

  OutPort& port_;
  const RemoteTarget target_;
  std::atomic<bool> stopping_{false};
  std::mutex reader_mutex_;  // reader_ swaps vs. unblock from the destructor
  std::unique_ptr<transport::ShmReader> reader_;
  UniqueFd socket_;
  double last_sent_timestamp_ = 0;
  bool sent_any_ = false;
  std::vector<unsigned char> buffer_;
  std::thread thread_;
};

/// The receiving end of a client: one UDP socket and one TCP listener on the
/// same port, and a thread that writes what arrives into the inbox ring of
/// the subscription it is addressed to.
class RemoteReceiver {
 public:
  /// Binds to `local_ip` (the address this host uses towards the manager)
  /// and starts the thread. Throws Failure.
  explicit RemoteReceiver(const std::string& local_ip);
  ~RemoteReceiver();
  RemoteReceiver(const RemoteReceiver&) = delete;
  RemoteReceiver& operator=(const RemoteReceiver&) = delete;

  /// "IP:PORT" to give the manager as receive_address.
  const std::string& address() const { return address_; }

  /// An inbox ring for packets of `message_size` bytes, kept `history`
  /// deep. Returns its descriptor (a duplicate, for ShmReader::attach).
  /// Throws Failure.
  UniqueFd open_inbox(const void* owner, std::uint32_t message_size, std::uint32_t history);
  /// Routes packets for `subscription_id` to the inbox of `owner` (replacing
  /// an earlier id of that owner, after a manager restart).
  void route(const void* owner, std::int64_t subscription_id);
  /// Forgets the inbox of `owner` (the subscription ended).
  void close_inbox(const void* owner);

 private:
  struct Inbox {
    std::unique_ptr<transport::ShmWriter> ring;
    std::int64_t subscription_id = -1;
    // Reassembly of the packet whose fragments are arriving (UDP).
    std::uint64_t sequence = 0;
    std::uint32_t received = 0;
    std::vector<unsigned char> assembly;
  };
  struct Connection {
    UniqueFd socket;
    std::string buffered;
  };

  void run();
  void on_datagram(const unsigned char* data, std::size_t size);
  void on_stream(Connection& connection);
  void deliver(std::int64_t subscription_id, std::uint64_t sequence, double timestamp, std::uint32_t packet_size,
               std::uint32_t offset, const unsigned char* fragment, std::size_t fragment_size);

  std::string address_;
  UniqueFd udp_;
  UniqueFd listener_;
  UniqueFd wake_;
  std::atomic<bool> stopping_{false};
  std::mutex mutex_;  // inboxes_ and routes_
  std::map<const void*, Inbox> inboxes_;
  std::map<std::int64_t, const void*> routes_;
  std::vector<Connection> connections_;  // receiver thread only
  std::thread thread_;
};

}  // namespace ln::clientlib
