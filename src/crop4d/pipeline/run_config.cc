#include "crop4d/pipeline/run_config.h"

#include <fmt/format.h>

#include <set>
#include <sstream>

#include "crop4d/core/error.h"
#include "crop4d/io/yaml_util.h"
#include "crop4d/pipeline/run_config_keys.h"

namespace crop4d::pipeline {

namespace {

RunConfig Parse(io::YamlFile& file) {
  RunConfig config;
  if (!file.root().IsDefined() || file.root().IsNull()) return config;  // an empty file
  if (!file.root().IsMap()) {
    file.Error(io::YamlLine(file.root()), "expected a map of sections");
    file.Finish();
  }
  std::set<std::string> sections(std::begin(kConfigSections), std::end(kConfigSections));
  for (const auto& item : file.root()) {
    const std::string name = item.first.as<std::string>();
    const std::int64_t line = io::YamlLine(item.first);
    const YAML::Node& value = item.second;
    if (sections.count(name) && !name.empty()) {
      if (!value.IsMap()) {
        if (!value.IsNull()) file.Error(line, "'" + name + "' must be a map of keys");
        continue;
      }
      for (const auto& entry : value) {
        const std::string key = entry.first.as<std::string>();
        const std::int64_t key_line = io::YamlLine(entry.first);
        const ConfigKey* found = nullptr;
        for (const ConfigKey& k : ConfigKeys()) {
          if (k.section == name && k.name == key) found = &k;
        }
        if (found == nullptr) {
          file.Error(key_line, "unknown key '" + name + "." + key + "' (docs/run.md lists them)");
          continue;
        }
        if (!entry.second.IsScalar()) {
          file.Error(key_line, "'" + name + "." + key + "' must be a single value");
          continue;
        }
        const std::string error = found->set(config, entry.second.Scalar());
        if (!error.empty()) file.Error(key_line, "'" + name + "." + key + "': " + error);
      }
      continue;
    }
    const ConfigKey* found = nullptr;
    for (const ConfigKey& k : ConfigKeys()) {
      if (std::string(k.section).empty() && k.name == name) found = &k;
    }
    if (found == nullptr) {
      file.Error(line, "unknown key '" + name + "' (docs/run.md lists them)");
      continue;
    }
    if (!value.IsScalar()) {
      file.Error(line, "'" + name + "' must be a single value");
      continue;
    }
    const std::string error = found->set(config, value.Scalar());
    if (!error.empty()) file.Error(line, "'" + name + "': " + error);
  }
  file.Finish();
  std::string message;
  if (!config.Check(&message)) throw InputError(file.path(), 0, message);
  return config;
}

}  // namespace

bool RunConfig::Check(std::string* message) const {
  auto fail = [message](const std::string& m) {
    if (message != nullptr) *message = m;
    return false;
  };
  // The command line sets it past the file's range check (crop4d run --threads).
  if (threads < 0 || threads > kMaxThreads) {
    return fail(fmt::format("threads must be 0 (all cores) to {} (got {})", kMaxThreads, threads));
  }
  if (associate.method != "both" && associate.method != fuse.method) {
    return fail("fuse.method '" + fuse.method + "' needs associate.method '" + fuse.method +
                "' or 'both' (got '" + associate.method + "')");
  }
  for (const auto& [section, why] :
       {std::pair{"slam.", slam.Check()}, std::pair{"associate.", associate.Check()},
        std::pair{"fuse.", fuse.Check()}, std::pair{"densify.", densify_options.Check()}}) {
    if (!why.empty()) return fail(section + why);
  }
  if (const std::string why = analyze.Check(); !why.empty()) return fail("analyze." + why);
  if (const std::string why = eval_options.Check(); !why.empty()) return fail("eval." + why);
  return true;
}

RunConfig ReadRunConfig(const std::string& path) {
  io::YamlFile file(path, nullptr);
  return Parse(file);
}

RunConfig ParseRunConfig(const std::string& name, const std::string& text) {
  io::YamlFile file(name, text, nullptr);
  return Parse(file);
}

std::string FormatRunConfig(const RunConfig& config) {
  RunConfig c = config;  // the table's accessors take a mutable configuration
  std::ostringstream out;
  out << "# crop4d run configuration (docs/run.md). Every key is optional; edit and pass back\n"
         "# with `crop4d run FIELD --workspace WS --config FILE`.\n";
  for (const char* section : kConfigSections) {
    const bool top = std::string(section).empty();
    if (!top) out << "\n" << section << ":\n";
    for (const ConfigKey& k : ConfigKeys()) {
      if (std::string(k.section) != section) continue;
      const std::string indent = top ? "" : "  ";
      out << indent << "# " << k.comment << "\n" << indent << k.name << ": " << k.get(c) << "\n";
    }
  }
  return out.str();
}

}  // namespace crop4d::pipeline
