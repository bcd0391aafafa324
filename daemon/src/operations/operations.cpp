#include "chromo/daemon/internal/operations/operations.hpp"

#include <algorithm>

namespace chromo::daemon {

void OperationControl::request_cancel() {
  std::lock_guard lock(mutex_);
  cancel_ = true;
  changed_.notify_all();
}
void OperationControl::request_pause() {
  std::lock_guard lock(mutex_);
  pause_ = true;
  changed_.notify_all();
}
void OperationControl::pause_by_daemon() { request_pause(); }
void OperationControl::request_resume() {
  std::lock_guard lock(mutex_);
  pause_ = false;
  changed_.notify_all();
}
bool OperationControl::cancel_requested() const {
  std::lock_guard lock(mutex_);
  return cancel_;
}
bool OperationControl::pause_requested() const {
  std::lock_guard lock(mutex_);
  return pause_;
}
bool OperationControl::wait_while_paused() {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return cancel_ || !pause_; });
  return !cancel_;
}
bool OperationControl::sleep_unless_cancelled(std::chrono::milliseconds duration) {
  std::unique_lock lock(mutex_);
  return !changed_.wait_for(lock, duration, [&] { return cancel_; });
}

std::vector<Event> EventBus::Subscription::next(std::chrono::milliseconds timeout, std::uint64_t* dropped) {
  std::unique_lock lock(mutex_);
  ready_.wait_for(lock, timeout, [&] { return !queue_.empty() || dropped_ > 0; });
  std::vector<Event> events(std::make_move_iterator(queue_.begin()), std::make_move_iterator(queue_.end()));
  queue_.clear();
  if (dropped) *dropped = dropped_;
  dropped_ = 0;
  return events;
}

std::shared_ptr<EventBus::Subscription> EventBus::subscribe(bool include_frames) {
  auto subscription = std::make_shared<Subscription>();
  subscription->include_frames_ = include_frames;
  std::lock_guard lock(mutex_);
  subscribers_.push_back(subscription);
  return subscription;
}

void EventBus::publish(Event event) {
  std::lock_guard lock(mutex_);
  event.sequence = ++sequence_;
  event.time = std::chrono::system_clock::now();
  std::erase_if(subscribers_, [](const auto& weak) { return weak.expired(); });
  for (const auto& weak : subscribers_) {
    auto subscriber = weak.lock();
    if (!subscriber || (event.kind == Event::Kind::kFrame && !subscriber->include_frames_)) continue;
    std::lock_guard sub_lock(subscriber->mutex_);
    if (subscriber->queue_.size() >= kBacklog) {
      ++subscriber->dropped_;
    } else {
      subscriber->queue_.push_back(event);
    }
    subscriber->ready_.notify_all();
  }
}

std::shared_ptr<OperationControl> OperationRegistry::add(session::OperationRecord record) {
  auto control = std::make_shared<OperationControl>();
  Event event;
  {
    std::lock_guard lock(mutex_);
    record.created = record.updated = std::chrono::system_clock::now();
    event.operation = record;
    const std::string id = record.id;
    entries_[id] = Entry{std::move(record), control, 1};
  }
  changed_.notify_all();
  event.kind = Event::Kind::kOperation;
  events_.publish(std::move(event));
  return control;
}

void OperationRegistry::add_past(session::OperationRecord record) {
  std::lock_guard lock(mutex_);
  auto id = record.id;
  entries_[id] = Entry{std::move(record), nullptr, 1};
}

void OperationRegistry::remove(const std::string& id) {
  {
    std::lock_guard lock(mutex_);
    entries_.erase(id);
  }
  changed_.notify_all();
}

void OperationRegistry::update(const std::string& id, const std::function<void(session::OperationRecord&)>& change) {
  Event event;
  {
    std::lock_guard lock(mutex_);
    auto entry = entries_.find(id);
    if (entry == entries_.end()) return;
    change(entry->second.record);
    entry->second.record.updated = std::chrono::system_clock::now();
    ++entry->second.version;
    event.operation = entry->second.record;
  }
  changed_.notify_all();
  event.kind = Event::Kind::kOperation;
  events_.publish(std::move(event));
}

std::optional<session::OperationRecord> OperationRegistry::get(const std::string& id) const {
  std::lock_guard lock(mutex_);
  auto entry = entries_.find(id);
  if (entry == entries_.end()) return std::nullopt;
  return entry->second.record;
}

std::shared_ptr<OperationControl> OperationRegistry::control(const std::string& id) const {
  std::lock_guard lock(mutex_);
  auto entry = entries_.find(id);
  return entry == entries_.end() ? nullptr : entry->second.control;
}

std::vector<session::OperationRecord> OperationRegistry::list() const {
  std::vector<session::OperationRecord> records;
  {
    std::lock_guard lock(mutex_);
    for (const auto& [id, entry] : entries_) records.push_back(entry.record);
  }
  std::sort(records.begin(), records.end(), [](const auto& a, const auto& b) {
    return a.created != b.created ? a.created > b.created : a.id > b.id;
  });
  return records;
}

std::optional<std::pair<session::OperationRecord, std::uint64_t>> OperationRegistry::wait_change(
    const std::string& id, std::uint64_t seen_version, std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  auto current = [&]() -> const Entry* {
    auto entry = entries_.find(id);
    return entry == entries_.end() ? nullptr : &entry->second;
  };
  changed_.wait_for(lock, timeout, [&] {
    const Entry* entry = current();
    return !entry || entry->version > seen_version;
  });
  const Entry* entry = current();
  if (!entry) return std::nullopt;
  return std::make_pair(entry->record, entry->version);
}

bool OperationRegistry::any_active() const {
  std::lock_guard lock(mutex_);
  return std::any_of(entries_.begin(), entries_.end(), [](const auto& item) { return !session::is_final(item.second.record.state); });
}

}  // namespace chromo::daemon
