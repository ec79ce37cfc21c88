#include "host/web/sample_hub.h"

#include <algorithm>

namespace dca {

std::uint32_t SampleHub::add_topic(const std::string& name, std::vector<std::string> fields, std::string units) {
  auto it = by_name_.find(name);
  std::uint32_t id = it != by_name_.end() ? it->second : next_id_++;
  Topic& t = topics_[id];
  if (t.fields != fields) histories_.erase(id);
  t.id = id;
  t.name = name;
  t.fields = std::move(fields);
  t.units = std::move(units);
  by_name_[name] = id;
  const auto observers = observers_;  // an observer may remove itself
  for (Observer* o : observers) o->on_topic(t);
  return id;
}

bool SampleHub::set_frames(std::uint32_t id, std::vector<frames::Frame> frames) {
  auto it = topics_.find(id);
  if (it == topics_.end()) return false;
  it->second.frames = std::move(frames);
  const auto observers = observers_;
  for (Observer* o : observers) o->on_topic(it->second);
  return true;
}

std::uint32_t SampleHub::add_message_topic(const std::string& name, std::string schema_name, std::string schema,
                                           std::string message, bool stream) {
  auto it = by_name_.find(name);
  const std::uint32_t id = it != by_name_.end() ? it->second : next_id_++;
  Topic& t = topics_[id];
  t = Topic{};
  t.id = id;
  t.name = name;
  t.schema_name = std::move(schema_name);
  t.schema = std::move(schema);
  t.message = std::move(message);
  t.stream = stream;
  by_name_[name] = id;
  const auto observers = observers_;
  for (Observer* o : observers) o->on_topic(t);
  return id;
}

std::uint32_t SampleHub::add_stream_topic(const std::string& name, std::string schema_name, std::string schema) {
  return add_message_topic(name, std::move(schema_name), std::move(schema), "", true);
}

bool SampleHub::publish_message(std::uint32_t id, std::int64_t t_ns, std::string_view json) {
  auto it = topics_.find(id);
  if (it == topics_.end() || !it->second.stream) return false;
  it->second.samples++;
  const auto observers = observers_;
  for (Observer* o : observers) o->on_message_sample(it->second, t_ns, json);
  return true;
}

void SampleHub::remove_topic(std::uint32_t id) {
  auto it = topics_.find(id);
  if (it == topics_.end()) return;
  by_name_.erase(it->second.name);
  topics_.erase(it);
  histories_.erase(id);
  const auto observers = observers_;
  for (Observer* o : observers) o->on_topic_removed(id);
}

bool SampleHub::publish(std::uint32_t id, std::int64_t t_ns, std::span<const double> values) {
  auto it = topics_.find(id);
  if (it == topics_.end()) return false;
  it->second.samples++;
  if (history_buckets_ > 0 && it->second.frames.empty()) histories_.try_emplace(id, history_buckets_).first->second.add(t_ns, values);
  const auto observers = observers_;
  for (Observer* o : observers) o->on_sample(it->second, t_ns, values);
  return true;
}

const SampleHub::Topic* SampleHub::topic(std::uint32_t id) const {
  auto it = topics_.find(id);
  return it == topics_.end() ? nullptr : &it->second;
}

const SampleHistory* SampleHub::history(std::uint32_t id) const {
  auto it = histories_.find(id);
  return it == histories_.end() ? nullptr : &it->second;
}

const SampleHub::Topic* SampleHub::find(const std::string& name) const {
  auto it = by_name_.find(name);
  return it == by_name_.end() ? nullptr : topic(it->second);
}

void SampleHub::add_observer(Observer* o) {
  if (std::find(observers_.begin(), observers_.end(), o) == observers_.end()) observers_.push_back(o);
}

void SampleHub::remove_observer(Observer* o) {
  observers_.erase(std::remove(observers_.begin(), observers_.end(), o), observers_.end());
}

}  // namespace dca
