#include "crop4d/workspace/json_file.h"

#include <filesystem>
#include <fstream>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"

namespace crop4d::workspace {

using json = nlohmann::json;

json ReadJsonOfSchema(const std::string& path, int schema, const std::string& rerun,
                      SchemaField field) {
  if (!std::filesystem::exists(path)) {
    throw InputError(path, 0, "missing (run `" + rerun + "` first)");
  }
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot be read");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::exception& e) {
    throw InputError(
        path, 0, std::string("not valid JSON (") + e.what() + "); rerun `" + rerun + " --force`");
  }
  if (!j.is_object()) {
    throw InputError(path, 0, "not a JSON object; rerun `" + rerun + " --force`");
  }
  const json found = j.value("schema", field == SchemaField::kOptional ? json(1) : json());
  if (!found.is_number_integer() || found.get<int>() != schema) {
    throw InputError(path, 0,
                     "written by another crop4d version (schema " +
                         (found.is_null() ? std::string("none") : found.dump()) +
                         ", this crop4d reads " + std::to_string(schema) + "); rerun `" + rerun +
                         " --force`");
  }
  return j;
}

void WriteJsonOfSchema(const std::string& path, json j, int schema) {
  if (schema > 1) j["schema"] = schema;
  io::WriteFileAtomic(path, j.dump(2) + "\n");
}

void ReadFields(const std::string& path, const std::string& rerun,
                const std::function<void()>& read) {
  try {
    read();
  } catch (const json::exception& e) {
    throw InputError(path, 0,
                     std::string("a missing or mistyped field (") + e.what() + "); rerun `" +
                         rerun + " --force`");
  }
}

}  // namespace crop4d::workspace
