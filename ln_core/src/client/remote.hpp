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
//                                        PacketAssembler -> inbox ShmWriter -> InPort
//
// Wire format of one packet (header fields little endian), kHeaderSize bytes:
// u32 magic "LNT2", u32 flags (bit 0: the payload is in big-endian byte
// order), u64 subscription_id, u64 stream, u64 joined_after, u64 sequence,
// f64 timestamp, u32 packet size, u32 offset of this fragment, then the
// fragment. UDP datagrams carry fragments of kMaxDatagramPayload bytes (the
// last one shorter); TCP carries whole packets, each preceded by a u32 frame
// length.
//
// Sequence numbers and loss. `sequence` is the publisher's own number of
// the packet (its segment's), `stream` names the publisher's numbering (a
// random number per publisher port, new when its numbering restarts), and
// `joined_after` is the publisher's newest packet when it first counted this
// subscription (subscribers_changed): the subscription's packets are the
// ones after it, exactly as for a local subscriber (client.cpp, joined_after),
// and the sender starts right there. The receiver creates the inbox ring of
// a stream when its first packet arrives, numbered from joined_after + 1,
// and writes each packet under the publisher's number (ShmWriter::write_as).
// So the port reports the publisher's sequence, and a packet lost on the
// network (or a fragmented one that stayed incomplete) is a gap its reader
// counts in `lost`, together with packets overwritten in the ring. Packets
// that arrive twice or late (not newer than the newest one written) are
// dropped, never delivered twice or backwards. Another stream (a new
// publisher) gets a fresh ring that the port switches to.
//
// Start-up. The publisher learns of a subscription from the manager and may
// send before the subscriber's client has processed its subscribe answer,
// i.e. before route() tells the receiver which port a subscription id is
// for. The receiver holds such packets (at most kHoldTime, kHoldBytes) and
// replays them when the route appears; ids of ended subscriptions are not
// held. Together with joined_after nothing is lost at start-up: the first
// packet the subscriber can get is the first one written after the
// publisher counted it.
//
// Byte order: payloads travel in the publisher's host byte order; a
// subscriber on a host of the other byte order gets LNE_WRONG_BYTE_ORDER
// from its reads instead of the data (no conversion).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
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
class DatagramFaults;

/// UDP fragments carry at most this many payload bytes: below the 64 KiB
/// UDP limit, and well below it for IPv4 reassembly buffers on the way.
inline constexpr std::uint32_t kMaxDatagramPayload = 60000;

/// One remote subscriber of a topic, as subscribers_changed lists it.
struct RemoteTarget {
  std::int64_t subscription_id = 0;
  double rate = -1;
  bool reliable = false;
  std::string address;  ///< "IP:PORT"
  /// The publisher's newest packet when it first counted the subscription
  /// (not part of the identity; the client fills it in).
  std::uint64_t joined_after = 0;
  bool operator<(const RemoteTarget& other) const;
  /// Parses "subscription_id rate reliable IP:PORT"; false if malformed.
  static bool parse(const std::string& text, RemoteTarget& target);
};

/// Whole packets of one subscription from fragments as they arrive over UDP
/// (lost, duplicated, reordered) or TCP: only packets newer than the newest
/// one completed come out, each once, in increasing sequence order. A packet
/// whose fragments are still incomplete when a fragment of a newer one
/// arrives is abandoned. No sockets, no rings: the receiver's bookkeeping.
class PacketAssembler {
 public:
  /// `newest`: packets up to this sequence are not wanted.
  explicit PacketAssembler(std::uint64_t newest = 0, std::uint32_t fragment_size = kMaxDatagramPayload)
      : newest_(newest), fragment_size_(fragment_size) {}
  /// One fragment of packet `sequence` (`packet_size` bytes, split into
  /// fragments of fragment_size bytes, the last one shorter). Returns the
  /// packet when this fragment completes it (valid until the next call),
  /// else nullptr: incomplete, not newer than newest(), a fragment already
  /// received, or not fitting the fragment layout.
  const unsigned char* add(std::uint64_t sequence, std::uint32_t packet_size, std::uint32_t offset,
                           const unsigned char* fragment, std::size_t fragment_size);
  /// The newest packet completed (or the starting point).
  std::uint64_t newest() const { return newest_; }

 private:
  std::uint64_t newest_;
  std::uint32_t fragment_size_;
  std::uint64_t assembling_ = 0;  // the packet being assembled, 0: none
  std::uint32_t missing_ = 0;     // its fragments not received yet
  std::vector<bool> have_;        // per fragment
  std::vector<unsigned char> packet_;
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
  bool send_datagram(const unsigned char* header, const unsigned char* payload, std::size_t length);

  OutPort& port_;
  const RemoteTarget target_;
  std::atomic<bool> stopping_{false};
  std::mutex reader_mutex_;  // reader_ swaps vs. unblock from the destructor
  std::unique_ptr<transport::ShmReader> reader_;
  std::uint64_t stream_ = 0;  // of the segment reader_ reads
  UniqueFd socket_;
  double last_sent_timestamp_ = 0;
  bool sent_any_ = false;
  std::vector<unsigned char> buffer_;
  std::unique_ptr<DatagramFaults> faults_;  // test builds only: see datagram_faults.hpp
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

  /// What the receiver tells the port of an inbox. Called from the
  /// receiver's thread (or route()) with the receiver's lock held, so never
  /// after close_inbox() returned; must not call back into the receiver.
  struct InboxHandlers {
    /// A new ring (the first, or one for a new publisher stream): the port
    /// reads it from now on. `generation` tells the rings of one inbox
    /// apart; packets after `written_before` are the port's.
    std::function<void(UniqueFd ring, std::int64_t generation, std::uint64_t written_before)> adopt;
    /// The data cannot be delivered (LNE_WRONG_BYTE_ORDER, ring creation failed).
    std::function<void(int code, const std::string& text)> fail;
  };
  /// The inbox of `owner` for packets of `message_size` bytes, kept
  /// `history` deep. Its rings are created when data arrives. Does nothing
  /// if the owner has one already.
  void open_inbox(const void* owner, std::uint32_t message_size, std::uint32_t history, InboxHandlers handlers);
  /// Routes packets for `subscription_id` to the inbox of `owner` (replacing
  /// an earlier id of that owner, after a manager restart), including those
  /// that arrived before and were held.
  void route(const void* owner, std::int64_t subscription_id);
  /// Forgets the inbox of `owner` (the subscription ended).
  void close_inbox(const void* owner);

  /// How long and how much the receiver holds for subscription ids it has
  /// no route for yet.
  static constexpr std::chrono::milliseconds kHoldTime{2000};
  static constexpr std::size_t kHoldBytes = 32u << 20;

 private:
  struct Inbox {
    std::uint32_t message_size = 1;
    std::uint32_t history = 1;
    InboxHandlers handlers;
    std::int64_t subscription_id = -1;
    std::unique_ptr<transport::ShmWriter> ring;  // of the current stream
    std::uint64_t stream = 0;
    std::int64_t generation = 0;
    std::vector<std::uint64_t> retired_streams;  // stragglers of these are dropped
    PacketAssembler assembler;
    bool failed = false;
    std::chrono::steady_clock::time_point new_streams_since{};  // rings made for new streams lately
    int new_streams = 0;
  };
  struct Connection {
    UniqueFd socket;
    std::string buffered;
  };
  struct Held {
    std::chrono::steady_clock::time_point arrived;
    std::int64_t subscription_id;
    std::vector<unsigned char> bytes;  // header + fragment
  };

  void run();
  // A datagram, or a TCP frame without its length: header + fragment.
  void on_packet(const unsigned char* data, std::size_t size);
  void on_stream(Connection& connection);
  /// Keeps what TCP connections hold of unfinished packets within a budget.
  void drop_largest_streams_over_budget();
  void deliver_locked(const unsigned char* data, std::size_t size, bool may_hold);
  void forget_id_locked(std::int64_t subscription_id);

  std::string address_;
  UniqueFd udp_;
  UniqueFd listener_;
  UniqueFd wake_;
  std::atomic<bool> stopping_{false};
  std::mutex mutex_;  // everything below up to connections_
  std::map<const void*, Inbox> inboxes_;
  std::map<std::int64_t, const void*> routes_;
  std::deque<Held> held_;
  std::size_t held_bytes_ = 0;
  std::deque<std::int64_t> ended_ids_;   // recently routed elsewhere or closed: not held
  std::vector<Connection> connections_;  // receiver thread only
  std::thread thread_;
};

}  // namespace ln::clientlib
