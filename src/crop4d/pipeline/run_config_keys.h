#pragma once

// The keys of `crop4d run`'s configuration file (run_config.h): for each, its section, name,
// comment, the option it sets and how its value is read and written. Parsing and formatting
// both go through this one table, so the file written to WS/crop4d.yaml always reads back to
// the same configuration. A key is bound to its option by the option's dotted path in
// RunConfig's field lists (stage_option_fields.h). Internal to run_config.cc.

#include <functional>
#include <string>
#include <vector>

#include "crop4d/pipeline/run_config.h"

namespace crop4d::pipeline {

// One key of the file.
struct ConfigKey {
  const char* section;  // "" for the top level
  const char* name;
  const char* comment;
  const char* field;  // "slam.front_end.num_neighbors"
  // The value as YAML text.
  std::function<std::string(RunConfig&)> get;
  // Sets the value from a YAML scalar; returns an error message, "" when valid.
  std::function<std::string(RunConfig&, const std::string&)> set;
};

// The sections of the file in the order they are written ("" is the top level).
inline constexpr const char* kConfigSections[] = {"",     "stages",  "slam",    "associate",
                                                  "fuse", "densify", "analyze", "eval"};

// Every key, section by section in the order of kConfigSections. Checks once that each key's
// field is in RunConfig's field lists, of its type (aborts otherwise: a programmer error).
const std::vector<ConfigKey>& ConfigKeys();

}  // namespace crop4d::pipeline
