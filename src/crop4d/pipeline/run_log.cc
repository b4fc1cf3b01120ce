#include "crop4d/pipeline/run_log.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"

namespace crop4d::pipeline {

namespace {

using json = nlohmann::json;

json ToJson(const StageRecord& s) {
  // NaN (unknown) is written as null.
  auto number = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  return json{{"name", s.name},
              {"status", s.status},
              {"seconds", s.seconds},
              {"cpu_seconds", number(s.cpu_seconds)},
              {"peak_rss_mb", number(s.peak_rss_mb)},
              {"done", s.done},
              {"skipped", s.skipped},
              {"failed", s.failed},
              {"messages", s.messages}};
}

}  // namespace

bool RunRecord::AnyStageFailed() const {
  for (const StageRecord& s : stages) {
    if (s.status == "failed") return true;
  }
  return false;
}

StageRecord* RunRecord::Stage(const std::string& name) {
  for (StageRecord& s : stages) {
    if (s.name == name) return &s;
  }
  return nullptr;
}

void WriteRunRecord(const std::string& path, const RunRecord& record) {
  json stages = json::array();
  for (const StageRecord& s : record.stages) stages.push_back(ToJson(s));
  json skipped = json::array();
  for (const SkippedItem& s : record.skipped) {
    skipped.push_back(
        {{"stage", s.stage}, {"session", s.session}, {"item", s.item}, {"reason", s.reason}});
  }
  const json j = {{"crop4d_version", record.crop4d_version},
                  {"field", record.field},
                  {"workspace", record.workspace},
                  {"started", record.started},
                  {"finished", record.finished.empty() ? json(nullptr) : json(record.finished)},
                  {"complete", record.complete},
                  {"threads", record.threads},
                  {"stages", stages},
                  {"skipped", skipped}};
  io::WriteFileAtomic(path, j.dump(2) + "\n");
}

RunRecord ReadRunRecord(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open the run record");
  RunRecord r;
  try {
    const json j = json::parse(in);
    r.crop4d_version = j.value("crop4d_version", "");
    r.field = j.value("field", "");
    r.workspace = j.value("workspace", "");
    r.started = j.value("started", "");
    if (j.contains("finished") && j["finished"].is_string()) r.finished = j["finished"];
    r.complete = j.value("complete", false);
    r.threads = j.value("threads", 0);
    for (const json& s : j.at("stages")) {
      StageRecord stage;
      stage.name = s.at("name");
      stage.status = s.at("status");
      stage.seconds = s.value("seconds", 0.0);
      // Absent in records of earlier versions; null when it was unknown.
      auto number = [&](const char* key) {
        return s.contains(key) && s[key].is_number() ? s[key].get<double>() : std::nan("");
      };
      stage.cpu_seconds = number("cpu_seconds");
      stage.peak_rss_mb = number("peak_rss_mb");
      stage.done = s.value("done", 0);
      stage.skipped = s.value("skipped", 0);
      stage.failed = s.value("failed", 0);
      stage.messages = s.value("messages", std::vector<std::string>{});
      r.stages.push_back(std::move(stage));
    }
    for (const json& s : j.at("skipped")) {
      r.skipped.push_back({s.value("stage", ""), s.value("session", ""), s.value("item", ""),
                           s.value("reason", "")});
    }
  } catch (const json::exception& e) {
    throw InputError(path, 0, std::string("malformed run record: ") + e.what());
  }
  return r;
}

std::string IsoTimeNow() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return buf;
}

RunLog::RunLog(const std::string& path) {
  file_ = std::fopen(path.c_str(), "a");
  if (file_ == nullptr) throw InputError(path, 0, "cannot open the run log for appending");
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                      std::chrono::system_clock::now().time_since_epoch())
                      .count();
  run_id_ = IsoTimeNow() + "-" + std::to_string(::getpid()) + "-" + std::to_string(ns % 1000000);
}

RunLog::~RunLog() {
  if (file_ != nullptr) std::fclose(file_);
}

void RunLog::Add(const std::string& stage, const std::string& item, const std::string& action,
                 double seconds, const std::string& message) {
  json j = {{"run", run_id_}, {"time", IsoTimeNow()}, {"stage", stage},
            {"item", item},   {"action", action},     {"seconds", seconds}};
  if (!message.empty()) j["message"] = message;
  const std::string line = j.dump() + "\n";
  std::lock_guard lock(mutex_);
  // One write per line, flushed: a kill leaves at most the last line incomplete.
  std::fwrite(line.data(), 1, line.size(), file_);
  std::fflush(file_);
}

std::vector<RunEvent> ReadRunLog(const std::string& path) {
  std::vector<RunEvent> events;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    const json j = json::parse(line, nullptr, /*allow_exceptions=*/false);
    if (!j.is_object()) continue;
    RunEvent e;
    e.run = j.value("run", "");
    e.time = j.value("time", "");
    e.stage = j.value("stage", "");
    e.item = j.value("item", "");
    e.action = j.value("action", "");
    e.seconds = j.value("seconds", 0.0);
    e.message = j.value("message", "");
    events.push_back(std::move(e));
  }
  return events;
}

std::shared_ptr<MessageCollector> MessageCollector::Install() {
  auto collector = std::make_shared<MessageCollector>();
  collector->set_level(spdlog::level::warn);
  spdlog::default_logger()->sinks().push_back(collector);
  return collector;
}

void MessageCollector::Remove() {
  auto& sinks = spdlog::default_logger()->sinks();
  sinks.erase(std::remove_if(sinks.begin(), sinks.end(),
                             [this](const spdlog::sink_ptr& s) { return s.get() == this; }),
              sinks.end());
}

std::vector<std::string> MessageCollector::Take(std::size_t limit) {
  std::lock_guard lock(mutex_);
  std::vector<std::string> out;
  out.swap(messages_);
  if (out.size() > limit) {
    const std::size_t dropped = out.size() - limit;
    out.resize(limit);
    out.push_back("... and " + std::to_string(dropped) + " more (WS/crop4d.log)");
  }
  return out;
}

void MessageCollector::sink_it_(const spdlog::details::log_msg& msg) {
  std::string text(msg.payload.data(), msg.payload.size());
  if (msg.level >= spdlog::level::err) text = "error: " + text;
  messages_.push_back(std::move(text));
}

}  // namespace crop4d::pipeline
