#include "bridge/sender_filter.hpp"

#include <fnmatch.h>

#include <algorithm>
#include <set>
#include <utility>

namespace msg_mapping::bridge {

SenderFilter::SenderFilter(IsBridge is_bridge, std::size_t hold, double pending)
    : is_bridge_(std::move(is_bridge)), hold_(std::max<std::size_t>(1, hold)), pending_(pending) {}

SenderFilter::Decision SenderFilter::decide(const Gid& gid) {
  const auto verdict = verdicts_.find(gid);
  if (verdict == verdicts_.end()) return Decision::Hold;
  if (!verdict->second) {
    ++dropped_;
    return Decision::Drop;
  }
  return Decision::Forward;
}

void SenderFilter::hold(const Gid& gid, HeldMessage message, double now) {
  auto [it, added] = held_.try_emplace(gid);
  if (added) it->second.first_seen = now;
  it->second.messages.push_back(std::move(message));
  if (it->second.messages.size() > hold_) it->second.messages.pop_front();
}

void SenderFilter::learn(const std::vector<Endpoint>& publishers, bool forget_departed) {
  for (const Endpoint& e : publishers)
    if (!e.node.empty() && !verdicts_.count(e.gid)) verdicts_[e.gid] = !is_bridge_(e.node);
  if (!forget_departed) return;
  std::set<Gid> present;
  for (const Endpoint& e : publishers) present.insert(e.gid);
  for (auto it = verdicts_.begin(); it != verdicts_.end();)
    it = present.count(it->first) ? std::next(it) : verdicts_.erase(it);
}

std::vector<HeldMessage> SenderFilter::release(double now) {
  std::vector<HeldMessage> out;
  for (auto it = held_.begin(); it != held_.end();) {
    auto verdict = verdicts_.find(it->first);
    if (verdict == verdicts_.end() && now - it->second.first_seen >= pending_) {
      verdict = verdicts_.emplace(it->first, true).first;
      nodeless_.push_back(it->first);
    }
    if (verdict == verdicts_.end()) {
      ++it;
      continue;
    }
    if (verdict->second) {
      for (auto& m : it->second.messages) out.push_back(std::move(m));
    } else {
      dropped_ += it->second.messages.size();
    }
    it = held_.erase(it);
  }
  return out;
}

std::size_t SenderFilter::held_count() const {
  std::size_t n = 0;
  for (const auto& entry : held_) n += entry.second.messages.size();
  return n;
}

bool SenderFilter::is_bridge(const Gid& gid) const {
  const auto verdict = verdicts_.find(gid);
  return verdict != verdicts_.end() && !verdict->second;
}

std::vector<Gid> SenderFilter::take_nodeless() { return std::exchange(nodeless_, {}); }

bool matches_any(const std::string& node, const std::vector<std::string>& patterns) {
  const std::string name = node.substr(node.rfind('/') + 1);
  return std::any_of(patterns.begin(), patterns.end(),
                     [&](const std::string& p) { return fnmatch(p.c_str(), name.c_str(), 0) == 0; });
}

}  // namespace msg_mapping::bridge
