#pragma once

// The figures of `crop4d analyze`: canopy height versus date per site, our method and the
// paper's single plane, with the heights a person measured when the field has them; and its
// table for the terminal (FormatAnalyzeReport, declared in analyze_stage.h).

#include <filesystem>
#include <string>
#include <vector>

#include "crop4d/io/dataset.h"
#include "crop4d/pipeline/analyze_stage.h"

namespace crop4d::pipeline {

// Reads FIELD/ground_truth/site_measurements.csv (site_id,date,height_m[,...]; extra columns are
// ignored). Throws InputError naming the file and line for a malformed row.
std::vector<io::SiteMeasurement> ReadSiteMeasurements(const std::string& path);

// Writes `dir`/heights.png (one panel per site) and `dir`/height_<site>.png; `results` holds
// `num_sessions` results per site, site-major as AnalyzeReport::sites. `measurements_csv` may
// be empty. Returns the names of the files written.
std::vector<std::string> WriteHeightPlots(const std::filesystem::path& dir,
                                          const std::vector<io::Site>& sites,
                                          const std::vector<SiteResult>& results,
                                          std::size_t num_sessions,
                                          const std::string& measurements_csv);

}  // namespace crop4d::pipeline
