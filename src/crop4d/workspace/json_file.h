#pragma once

// JSON workspace files whose first version carried no "schema" field (the association
// summaries, WS/fused/quality.json, WS/eval/metrics.json): a file without the field is of
// schema 1, a later version stamps "schema": <n>. So their bytes stay as they were while the
// readers still refuse a file of another version.

#include <functional>
#include <nlohmann/json.hpp>
#include <string>

namespace crop4d::workspace {

// Whether a file must carry "schema" (the stage summaries) or may leave it out for schema 1.
enum class SchemaField { kOptional, kRequired };

// Reads the JSON object in `path`, of schema `schema` (with SchemaField::kOptional, a file
// without "schema" is of schema 1). Throws InputError naming the file when it is missing, not
// JSON, not an object or of another schema; `rerun` is the command that writes the file (for
// the messages).
nlohmann::json ReadJsonOfSchema(const std::string& path, int schema, const std::string& rerun,
                                SchemaField field = SchemaField::kOptional);

// Writes `j` atomically, 2-space indented with a final newline; stamps "schema" when `schema`
// is above 1.
void WriteJsonOfSchema(const std::string& path, nlohmann::json j, int schema);

// Runs `read` (which reads fields of a parsed file); a missing or mistyped field becomes an
// InputError on `path` saying to rerun `rerun --force`.
void ReadFields(const std::string& path, const std::string& rerun,
                const std::function<void()>& read);

}  // namespace crop4d::workspace
