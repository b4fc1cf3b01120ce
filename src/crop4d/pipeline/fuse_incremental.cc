#include "crop4d/pipeline/fuse_incremental.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <deque>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <unordered_map>

#include "crop4d/core/error.h"
#include "crop4d/core/hash.h"
#include "crop4d/core/stopwatch.h"
#include "crop4d/core/version.h"
#include "crop4d/io/checksummed_file.h"
#include "crop4d/io/tum.h"
#include "crop4d/pipeline/fuse_outputs.h"
#include "crop4d/pipeline/season_quality.h"
#include "crop4d/pipeline/stage_option_fields.h"
#include "crop4d/workspace/fused_camera.h"
#include "crop4d/workspace/json_file.h"
#include "crop4d/workspace/pass_files.h"
#include "crop4d/workspace/stage_files.h"
#include "crop4d/workspace/stage_summary.h"

namespace crop4d::pipeline::fuse {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

// A step's landmarks (landmarks.bin), little-endian:
//   char[8] magic "C4DFLMK\0", u32 version (kStepLandmarksVersion)
//   u32 P; P × { u32 n; n bytes: pass label "<session>/<pass>" }
//   u64 L; L × { f64 x, y, z; u8 r, g, b; u32 n; n × { u32 pass (into the labels), i32 state,
//                f64 u, v (distorted pixel) } }
//   u64 FNV-1a 64 checksum of every byte above
constexpr char kStepLandmarksMagic[io::kChecksummedMagicSize] = {'C', '4', 'D', 'F',
                                                                 'L', 'M', 'K', '\0'};
constexpr std::uint32_t kStepLandmarksVersion = 1;
constexpr std::size_t kMaxLabelBytes = 4096;

struct StepLandmarks {
  std::vector<std::string> passes;
  std::vector<Eigen::Vector3d> positions;
  // Observations name their pass by its index in `passes`.
  std::vector<fusion::JointLandmark> landmarks;
};

void WriteStepLandmarks(const fs::path& path, const StepLandmarks& step) {
  io::ByteBuffer bytes;
  bytes.Put<std::uint32_t>(static_cast<std::uint32_t>(step.passes.size()));
  for (const std::string& label : step.passes) bytes.PutString(label, kMaxLabelBytes, "pass label");
  bytes.Put<std::uint64_t>(step.landmarks.size());
  for (std::size_t l = 0; l < step.landmarks.size(); ++l) {
    for (int k = 0; k < 3; ++k) bytes.Put<double>(step.positions[l](k));
    bytes.PutBytes(step.landmarks[l].color.data(), 3);
    bytes.Put<std::uint32_t>(static_cast<std::uint32_t>(step.landmarks[l].observations.size()));
    for (const fusion::JointObservation& o : step.landmarks[l].observations) {
      bytes.Put<std::uint32_t>(static_cast<std::uint32_t>(o.pass));
      bytes.Put<std::int32_t>(o.state);
      bytes.Put<double>(o.pixel.x());
      bytes.Put<double>(o.pixel.y());
    }
  }
  io::ChecksummedFileWriter writer(path.string(), kStepLandmarksMagic, kStepLandmarksVersion);
  writer.Write(bytes);
  writer.Commit();
}

StepLandmarks ReadStepLandmarks(const fs::path& path) {
  const std::string where = path.string();
  const std::string rerun = " (rerun `crop4d fuse --force`)";
  io::ChecksummedFileReader reader(where, kStepLandmarksMagic, kStepLandmarksVersion,
                                   "fused step landmarks");
  if (reader.status() != io::ChecksummedFileStatus::kOk) {
    throw InputError(where + ": " + reader.detail() + rerun);
  }
  const auto get = [&](auto* value) {
    if (!reader.Get(value)) throw InputError(where + ": truncated" + rerun);
  };
  StepLandmarks step;
  std::uint32_t num_passes = 0;
  get(&num_passes);
  for (std::uint32_t p = 0; p < num_passes; ++p) {
    std::uint32_t length = 0;
    get(&length);
    if (length > kMaxLabelBytes) throw InputError(where + ": corrupt pass label" + rerun);
    std::string label(length, '\0');
    if (!reader.Read(label.data(), length)) throw InputError(where + ": truncated" + rerun);
    step.passes.push_back(std::move(label));
  }
  std::uint64_t count = 0;
  get(&count);
  // Each landmark takes at least 31 bytes: a corrupt count cannot allocate beyond the file.
  if (count > reader.remaining() / 31) throw InputError(where + ": corrupt landmark count" + rerun);
  step.positions.resize(count);
  step.landmarks.resize(count);
  for (std::uint64_t l = 0; l < count; ++l) {
    for (int k = 0; k < 3; ++k) get(&step.positions[l](k));
    for (int c = 0; c < 3; ++c) get(&step.landmarks[l].color[c]);
    std::uint32_t n = 0;
    get(&n);
    if (n > reader.remaining() / 24)
      throw InputError(where + ": corrupt observation count" + rerun);
    for (std::uint32_t o = 0; o < n; ++o) {
      std::uint32_t pass = 0;
      fusion::JointObservation obs;
      get(&pass);
      get(&obs.state);
      get(&obs.pixel.x());
      get(&obs.pixel.y());
      if (pass >= num_passes) throw InputError(where + ": observation of an unknown pass" + rerun);
      obs.pass = static_cast<int>(pass);
      step.landmarks[l].observations.push_back(obs);
    }
  }
  if (reader.Finish("the landmarks") != io::ChecksummedFileStatus::kOk) {
    throw InputError(where + ": " + reader.detail() + rerun);
  }
  return step;
}

std::string StateFileName(const LoadedPass& pass) {
  return pass.data.session + "__" + pass.data.pass.id + ".csv";
}

// The season as the steps see it: each pass's session index, each session's passes, the
// association files by name with their hashes.
struct SeasonIndex {
  std::vector<int> session_of;                // per pass of the season
  std::vector<std::vector<int>> passes_of;    // per session
  std::map<std::string, fs::path> files;      // association files by file name
  std::map<std::string, std::string> hashes;  // and their FileHash
};

SeasonIndex IndexSeason(const SeasonPasses& season, const std::vector<fs::path>& files) {
  SeasonIndex index;
  std::map<std::string, int> session_index;
  for (std::size_t s = 0; s < season.sessions.size(); ++s) {
    session_index[season.sessions[s]] = static_cast<int>(s);
  }
  index.passes_of.resize(season.sessions.size());
  for (std::size_t p = 0; p < season.passes.size(); ++p) {
    const int s = session_index.at(season.passes[p]->data.session);
    index.session_of.push_back(s);
    index.passes_of[s].push_back(static_cast<int>(p));
  }
  for (const fs::path& path : files) {
    index.files[path.filename().string()] = path;
    index.hashes[path.filename().string()] = workspace::FileHash(path);
  }
  return index;
}

// The passes of a step (season indices, in order) and whether each is held.
std::vector<int> StepPasses(const SeasonIndex& index, const FuseStep& step,
                            std::vector<bool>* held) {
  std::vector<int> passes;
  held->clear();
  const int end = step.held_after >= 0 ? step.held_after : step.last;
  for (int s = step.held >= 0 ? step.held : step.first; s <= end; ++s) {
    for (const int p : index.passes_of[s]) {
      passes.push_back(p);
      held->push_back(s == step.held || s == step.held_after);
    }
  }
  return passes;
}

// The association files between two passes of the step, not both held, sorted by name.
std::vector<fs::path> StepAssociationFiles(const SeasonPasses& season, const SeasonIndex& index,
                                           const std::vector<int>& passes,
                                           const std::vector<bool>& held) {
  std::set<std::string> names;
  for (std::size_t i = 0; i < passes.size(); ++i) {
    for (std::size_t j = 0; j < passes.size(); ++j) {
      if (i == j || (held[i] && held[j])) continue;
      const workspace::PassData& a = season.passes[passes[i]]->data;
      const workspace::PassData& b = season.passes[passes[j]]->data;
      const std::string name =
          association::AssociationFileName({a.session, a.pass.id}, {b.session, b.pass.id});
      if (index.files.count(name)) names.insert(name);
    }
  }
  std::vector<fs::path> files;
  for (const std::string& name : names) files.push_back(index.files.at(name));
  return files;
}

// The options as a step's fingerprint takes them: without those that choose the steps (which
// the steps' own fields carry), so that a full fuse after a fuse session by session solves only
// its sweeps. `full` stays, as false, as in the fingerprints before full_sweeps and one_problem.
json StepOptionsJson(const FuseStageOptions& options) {
  json j = FuseOptionsJson(options);
  j["full"] = false;
  j.erase("full_sweeps");
  j.erase("one_problem");
  return j;
}

// The fingerprint of a step: the previous step's, the stage's revision, crop4d's version, the
// options, the sessions it optimises and holds, its passes and their association files.
std::string StepStamp(const std::string& previous, const FuseStep& step, const SeasonPasses& season,
                      const SeasonIndex& index, const std::vector<int>& passes,
                      const std::vector<bool>& held, const std::vector<fs::path>& files,
                      const FuseStageOptions& options) {
  Fnv1aHasher h;
  h.AddString(previous);
  h.Add(kFuseStageRevision);
  h.AddString(kVersion);
  h.AddString(StepOptionsJson(options).dump());
  h.Add(step.first);
  h.Add(step.held);
  h.Add(step.last);
  if (step.sweep > 0) {  // the steps that add a session keep the fingerprints they had
    h.Add(step.held_after);
    h.Add(step.sweep);
    h.Add(static_cast<int>(step.backward));
  }
  for (std::size_t i = 0; i < passes.size(); ++i) {
    h.AddString(season.passes[passes[i]]->data.label());
    h.AddString(season.passes[passes[i]]->data.fingerprint);
    h.Add(static_cast<int>(held[i]));
  }
  for (const fs::path& f : files) {
    h.AddString(f.filename().string());
    h.AddString(index.hashes.at(f.filename().string()));
  }
  return std::to_string(h.hash());
}

// A rig camera of the step's free passes: its calibration and the labels of its passes.
struct StepCamera {
  fusion::RefinedCalibration calibration;
  std::vector<std::string> passes;
};

// The rig's cameras a step leaves for its free passes (step.json "cameras" and the camera
// files), as the next step carries them; the cameras of its held passes (their calibration as
// an earlier step left it) are not among them.
std::vector<StepCamera> ReadStepCalibrations(const fs::path& dir, const json& step) {
  std::vector<StepCamera> calibrations;
  for (const json& c : step.at("cameras")) {
    if (c.at("held").get<bool>()) continue;
    const workspace::FusedCamera written =
        workspace::ReadFusedCamera((dir / c.at("written").get<std::string>()).string());
    const workspace::FusedCamera refined =
        workspace::ReadFusedCamera((dir / c.at("file").get<std::string>()).string());
    fusion::RefinedCalibration r;
    r.refined = c.at("refined").get<bool>();
    r.num_cross_observations = c.at("cross_observations").get<std::int64_t>();
    r.written_camera = written.intrinsics;
    r.written_body_from_camera = written.body_from_camera;
    r.camera = refined.intrinsics;
    r.body_from_camera = refined.body_from_camera;
    calibrations.push_back({r, c.at("passes").get<std::vector<std::string>>()});
  }
  return calibrations;
}

json ReadStepJson(const fs::path& dir) {
  return workspace::ReadJsonOfSchema((dir / "step.json").string(), 1, "crop4d fuse",
                                     workspace::SchemaField::kOptional);
}

// The time offset of every pass that the step in `dir` optimised, by pass label (nullopt: none
// estimated).
std::map<std::string, std::optional<double>> StepTimeOffsets(const fs::path& dir) {
  const json step = ReadStepJson(dir);
  std::map<std::string, std::optional<double>> offsets;
  workspace::ReadFields((dir / "step.json").string(), "crop4d fuse", [&] {
    for (const json& p : step.at("passes")) {
      const std::string label =
          p.at("session").get<std::string>() + "/" + p.at("pass").get<std::string>();
      offsets[label] = p.contains("time_offset_s")
                           ? std::optional<double>(p.at("time_offset_s").get<double>())
                           : std::nullopt;
    }
  });
  return offsets;
}

// Starts each pass of a step where the latest earlier step that optimised its session left it
// (`source_dirs[p]`, empty: none, row SLAM's states): states and time offset. Every pass starts
// from the calibration of the previous step's free passes (`previous_dir`, its last camera of a
// calibration as written): a pass held here was free in an earlier step, and a session added
// starts from the latest calibration. Returns the calibrations it carried in.
std::vector<fusion::RefinedCalibration> StartFromEarlierSteps(
    const std::vector<fs::path>& source_dirs, const fs::path& previous_dir, PassList* passes,
    std::deque<geometry::PinholeRadTan>* storage) {
  std::map<fs::path, std::map<std::string, std::optional<double>>> offsets_of;
  for (std::size_t p = 0; p < passes->size(); ++p) {
    const fs::path& dir = source_dirs[p];
    if (dir.empty()) continue;  // a pass of the session this step adds
    if (!offsets_of.count(dir)) offsets_of[dir] = StepTimeOffsets(dir);
    LoadedPass& pass = *(*passes)[p];
    const auto it = offsets_of[dir].find(pass.data.label());
    if (it == offsets_of[dir].end()) {
      throw InputError((dir / "step.json").string() + ": no pass " + pass.data.label() +
                       " (rerun `crop4d fuse --force`)");
    }
    const fs::path states = dir / "states" / StateFileName(pass);
    std::vector<slam::RowState> start = workspace::ReadPassStates(states.string());
    if (start.size() != pass.input.initial_states.size()) {
      throw InputError(states.string() + ": " + std::to_string(start.size()) +
                       " states, the pass has " + std::to_string(pass.input.initial_states.size()) +
                       " (rerun `crop4d fuse --force`)");
    }
    pass.input.initial_states = std::move(start);
    if (it->second) pass.input.time_offset_s = *it->second;
  }
  std::vector<fusion::RefinedCalibration> carried;
  const json previous = ReadStepJson(previous_dir);
  workspace::ReadFields((previous_dir / "step.json").string(), "crop4d fuse", [&] {
    for (StepCamera& c : ReadStepCalibrations(previous_dir, previous)) {
      carried.push_back(std::move(c.calibration));
    }
  });
  std::vector<slam::RowOptimiser::Input> inputs;
  for (const auto& pass : *passes) inputs.push_back(pass->input);
  fusion::UseRefinedCalibrations(carried, &inputs, storage);
  for (std::size_t p = 0; p < passes->size(); ++p) {
    (*passes)[p]->input.camera = inputs[p].camera;
    (*passes)[p]->input.body_from_camera = inputs[p].body_from_camera;
  }
  return carried;
}

// How far a solve moved the free passes from where it started them: the largest RMS change of a
// pass's body positions (m).
double LargestMove(const PassList& passes, const std::vector<bool>& held,
                   const fusion::JointOptimiser::Result& result) {
  double largest = 0;
  for (std::size_t p = 0; p < passes.size(); ++p) {
    const std::vector<slam::RowState>& start = passes[p]->input.initial_states;
    if (held[p] || start.empty() || result.states[p].size() != start.size()) continue;
    double sum_sq = 0;
    for (std::size_t k = 0; k < start.size(); ++k) {
      sum_sq += (result.states[p][k].nav.world_from_body.translation() -
                 start[k].nav.world_from_body.translation())
                    .squaredNorm();
    }
    largest = std::max(largest, std::sqrt(sum_sq / static_cast<double>(start.size())));
  }
  return largest;
}

json PassReportJson(const FusePassReport& pr, const std::optional<double>& time_offset_s) {
  json j = {{"session", pr.session},
            {"pass", pr.pass},
            {"images", pr.images},
            {"mean_shift_m", {pr.mean_shift.x(), pr.mean_shift.y(), pr.mean_shift.z()}},
            {"rotation_change_deg", pr.rotation_change_deg}};
  if (time_offset_s) j["time_offset_s"] = *time_offset_s;
  return j;
}

FusePassReport PassReportFromJson(const json& j) {
  FusePassReport pr;
  pr.session = j.at("session").get<std::string>();
  pr.pass = j.at("pass").get<std::string>();
  pr.images = j.at("images").get<int>();
  const auto shift = j.at("mean_shift_m").get<std::array<double, 3>>();
  pr.mean_shift = Eigen::Vector3d(shift[0], shift[1], shift[2]);
  pr.rotation_change_deg = j.at("rotation_change_deg").get<double>();
  return pr;
}

struct StepContext {
  const SeasonPasses& season;
  const SeasonIndex& index;
  const std::vector<FuseStep>& steps;
  const std::vector<bool>& protects;  // per pass of the season
  const std::string& workspace;
  const FuseStageOptions& options;
  const workspace::Layout& layout;
};

// Solves step `s` and writes its folder and the outputs of the sessions it makes final.
FuseStepReport RunStep(const StepContext& ctx, std::size_t s, const std::string& stamp,
                       FuseReport* report) {
  const auto start = Clock::now();
  const FuseStep& step = ctx.steps[s];
  std::vector<bool> held;
  const std::vector<int> season_passes = StepPasses(ctx.index, step, &held);
  const std::vector<fs::path> files =
      StepAssociationFiles(ctx.season, ctx.index, season_passes, held);
  FuseStepReport out;
  out.session = ctx.season.sessions[step.last];
  out.name = StepFolderName(step, ctx.season.sessions);
  out.sweep = step.sweep;
  for (int k = step.first; k <= step.last; ++k) out.optimised.push_back(ctx.season.sessions[k]);
  for (const int k : {step.held, step.held_after}) {
    if (k >= 0) out.held.push_back(ctx.season.sessions[k]);
  }
  std::string held_text;
  for (const std::string& h : out.held) held_text += (held_text.empty() ? "" : ", ") + h;
  spdlog::info("fuse: step {}/{}: {} {} ({} passes; optimising {} session(s), holding {})", s + 1,
               ctx.steps.size(),
               step.sweep == 0 ? std::string("session")
                               : fmt::format("sweep {} {}, up to", step.sweep,
                                             step.backward ? "backward" : "forward"),
               out.session, season_passes.size(), out.optimised.size(),
               held_text.empty() ? "none" : held_text);

  // The step's passes, their problems, and where the previous step left them.
  PassList passes;
  std::map<association::PassRef, int> pass_index;
  std::vector<bool> protects;
  for (const int g : season_passes) {
    auto loaded = std::make_unique<LoadedPass>();
    loaded->data.session = ctx.season.passes[g]->data.session;
    loaded->data.pass = ctx.season.passes[g]->data.pass;
    LoadPassProblem(ctx.workspace, loaded.get());
    pass_index[{loaded->data.session, loaded->data.pass.id}] = static_cast<int>(passes.size());
    passes.push_back(std::move(loaded));
    protects.push_back(ctx.protects[g]);
  }
  const fs::path steps_dir = ctx.layout.FusedStepsDir();
  std::deque<geometry::PinholeRadTan> carried_cameras;
  // The calibrations carried in, to report the step's own against the calibration as written.
  std::vector<fusion::RefinedCalibration> carried;
  if (s > 0) {
    std::vector<fs::path> sources;
    for (const int g : season_passes) {
      const int from = SourceStep(ctx.steps, s, ctx.index.session_of[g]);
      sources.push_back(
          from < 0 ? fs::path() : steps_dir / StepFolderName(ctx.steps[from], ctx.season.sessions));
    }
    const fs::path previous_dir = steps_dir / StepFolderName(ctx.steps[s - 1], ctx.season.sessions);
    carried = StartFromEarlierSteps(sources, previous_dir, &passes, &carried_cameras);
  }

  FuseReport step_report;
  std::vector<SessionPair> session_pairs;
  const fusion::CrossPassTracks graph =
      BuildLandmarkGraph(passes, pass_index, files, ctx.options, &step_report, &session_pairs);
  const std::vector<bool> every_pass(passes.size(), true);
  const std::vector<fusion::JointLandmark> landmarks =
      JoinLandmarks(graph, passes, every_pass, &step_report.num_conflicting_matches);
  const std::vector<fusion::JointGroundTie> ties =
      GroundTies(passes, session_pairs, ctx.options, &step_report);
  fusion::JointOptimiser::Result result =
      SolveJoint(graph, passes, landmarks, ties, protects, held, ctx.options);
  ReportEarlierRefinement(carried, &result);
  out.moved_m = LargestMove(passes, held, result);

  // The sessions this step makes final get their outputs.
  const std::vector<std::vector<geometry::Rigid3>> cameras =
      FusedCameras(passes, result, &step_report);
  const std::vector<workspace::FusedCamera> intrinsics = FusedIntrinsics(passes, result);
  std::vector<std::string> final_sessions;
  for (const int k : FinalSessions(ctx.steps, s)) {
    final_sessions.push_back(ctx.season.sessions[k]);
  }
  WriteSessionOutputs(passes, cameras, intrinsics, final_sessions, ctx.options, ctx.layout);

  // The step's folder, written aside and renamed.
  const fs::path dir = steps_dir / out.name;
  const fs::path tmp = steps_dir / ("." + out.name + ".tmp");
  fs::remove_all(tmp);
  fs::create_directories(tmp / "states");
  json pass_list = json::array();
  for (std::size_t p = 0; p < passes.size(); ++p) {
    if (held[p]) continue;
    workspace::WritePassStates((tmp / "states" / StateFileName(*passes[p])).string(),
                               result.states[p]);
    pass_list.push_back(PassReportJson(step_report.passes[p], result.time_offsets_s[p]));
  }
  json camera_list = json::array();
  for (std::size_t c = 0; c < result.calibrations.size(); ++c) {
    const fusion::RefinedCalibration& r = result.calibrations[c];
    const std::string name = "camera-" + std::to_string(c);
    workspace::WriteFusedCamera((tmp / (name + ".json")).string(),
                                {r.camera, r.body_from_camera, r.refined, r.RotationChangeDeg()});
    workspace::WriteFusedCamera((tmp / (name + "-written.json")).string(),
                                {r.written_camera, r.written_body_from_camera, false, 0.0});
    json labels = json::array();
    bool camera_held = true;
    for (const int p : r.passes) {
      labels.push_back(passes[p]->data.label());
      camera_held = camera_held && held[p];
    }
    camera_list.push_back({{"passes", labels},
                           {"held", camera_held},
                           {"refined", r.refined},
                           {"cross_observations", r.num_cross_observations},
                           {"file", name + ".json"},
                           {"written", name + "-written.json"}});
  }
  // The landmarks whose latest session is the step's last (any session up to it when the step
  // starts at the season's first): a landmark seen by the held session after the window belongs
  // to a step that optimises that session.
  const int own_from = step.first == 0 ? 0 : step.last;
  StepLandmarks owned;
  for (const auto& pass : passes) owned.passes.push_back(pass->data.label());
  for (std::size_t l = 0; l < result.landmarks_world.size(); ++l) {
    const fusion::JointLandmark& given = landmarks[result.landmark_ids[l]];
    fusion::JointLandmark kept;
    kept.color = given.color;
    int latest = -1;
    for (std::size_t o = 0; o < given.observations.size(); ++o) {
      if (!result.observations_kept[l][o]) continue;
      kept.observations.push_back(given.observations[o]);
      latest = std::max(latest, ctx.index.session_of[season_passes[given.observations[o].pass]]);
    }
    if (latest < own_from || latest > step.last) continue;
    owned.positions.push_back(result.landmarks_world[l]);
    owned.landmarks.push_back(std::move(kept));
  }
  WriteStepLandmarks(tmp / "landmarks.bin", owned);

  out.passes = static_cast<int>(passes.size());
  out.landmarks = result.summary.num_landmarks;
  out.observations = result.summary.num_observations;
  out.seconds = SecondsSince(start);
  json step_json = {{"fingerprint", stamp},
                    {"session", out.session},
                    {"optimised", out.optimised},
                    {"held", out.held},
                    {"final_sessions", final_sessions},
                    {"passes", pass_list},
                    {"cameras", camera_list},
                    {"joint", JointSummaryJson(result.summary)},
                    {"associations",
                     {{"files", step_report.num_association_files},
                      {"cross_matches", step_report.num_cross_matches},
                      {"thinned_matches", step_report.num_thinned_matches},
                      {"conflicting_matches", step_report.num_conflicting_matches},
                      {"invalid_matches", step_report.num_invalid_matches}}},
                    {"ground_ties", TiePairsJson(step_report.tie_pairs)},
                    {"owned_landmarks", owned.landmarks.size()},
                    {"moved_m", out.moved_m},
                    {"seconds", out.seconds}};
  // Its own files, and apart the outputs of each session it made final: they are its results
  // too (a damaged one makes the step run again) for as long as no later step makes that
  // session final instead (a session added after it), which writes them again.
  json session_outputs = json::object();
  for (const std::string& session : final_sessions) {
    std::vector<std::string> files;
    for (const fs::path& f : {ctx.layout.FusedPoses(session), ctx.layout.FusedCamera(session),
                              ctx.layout.FusedSparse(session)}) {
      if (fs::exists(f)) files.push_back(f.lexically_relative(ctx.layout.FusedDir()).string());
    }
    workspace::RecordOutputs(&session_outputs[session], ctx.layout.FusedDir(), files);
  }
  step_json["session_outputs"] = session_outputs;
  workspace::RecordOutputs(&step_json, tmp, workspace::FilesBelow(tmp));
  workspace::WriteJsonOfSchema((tmp / "step.json").string(), step_json, 1);
  fs::remove_all(dir);
  fs::rename(tmp, dir);

  report->tie_pairs.insert(report->tie_pairs.end(), step_report.tie_pairs.begin(),
                           step_report.tie_pairs.end());
  spdlog::info(
      "fuse: step {}/{} done in {:.1f} s: {} landmarks, {} observations; the passes moved at most "
      "{:.2f} cm (RMS of a pass)",
      s + 1, ctx.steps.size(), out.seconds, out.landmarks, out.observations, 100 * out.moved_m);
  return out;
}

// Whether a step's folder has `stamp` and intact files, and the outputs of the sessions it makes
// final (`final_sessions`, indices) are those it wrote.
bool StepUpToDate(const fs::path& dir, const std::string& stamp,
                  const std::vector<int>& final_sessions, const SeasonPasses& season,
                  const workspace::Layout& layout, std::string* why) {
  if (!workspace::SummaryUpToDate(dir / "step.json", stamp, why)) return false;
  try {
    const json step = ReadStepJson(dir);
    for (const int k : final_sessions) {
      const std::string& session = season.sessions[k];
      const json& outputs = step.at("session_outputs");
      if (!outputs.contains(session)) {
        *why = "it did not write the outputs of " + session;
        return false;
      }
      if (!workspace::OutputsIntact(layout.FusedDir(), outputs.at(session), why)) return false;
    }
  } catch (const std::exception& e) {
    *why = e.what();
    return false;
  }
  return true;
}

// The key of a camera as written (its intrinsics and T_BS), to follow it across the steps.
std::string WrittenCameraKey(const fusion::RefinedCalibration& c) {
  const geometry::PinholeRadTan& k = c.written_camera;
  const Eigen::Quaterniond& q = c.written_body_from_camera.rotation();
  const Eigen::Vector3d& t = c.written_body_from_camera.translation();
  json j = {k.width, k.height, k.fx,  k.fy,  k.cx,  k.cy,  k.k1,  k.k2,  k.p1,
            k.p2,    k.k3,     q.x(), q.y(), q.z(), q.w(), t.x(), t.y(), t.z()};
  return j.dump();
}

// The season's outputs from the steps' folders and the sessions' fused outputs: the per-pass
// reports, time offsets and the rig's cameras into `report` and `result`, the landmarks,
// landmarks.ply, the COLMAP model and summary.json.
void AssembleSeason(SeasonPasses& season, const std::vector<FuseStep>& steps,
                    const std::string& stamp, const FuseStageOptions& options,
                    const workspace::Layout& layout, FuseReport* report) {
  const fs::path steps_dir = layout.FusedStepsDir();
  const std::size_t num_passes = season.passes.size();
  fusion::JointOptimiser::Result result;
  result.time_offsets_s.resize(num_passes);
  report->passes.assign(num_passes, {});
  std::vector<json> step_jsons;
  json ground_ties = json::array();
  json step_list = json::array();
  // Each camera as written, followed over the steps: its latest calibration, every pass of it.
  std::map<std::string, fusion::RefinedCalibration> cameras_by_key;
  std::vector<std::string> camera_order;
  fusion::JointOptimiser::Summary joint;
  for (std::size_t s = 0; s < steps.size(); ++s) {
    const fs::path dir = steps_dir / StepFolderName(steps[s], season.sessions);
    const json j = ReadStepJson(dir);
    workspace::ReadFields((dir / "step.json").string(), "crop4d fuse", [&] {
      AddJointSummary(JointSummaryFromJson(j.at("joint")), &joint);
      const json& a = j.at("associations");
      report->num_association_files += a.at("files").get<int>();
      report->num_cross_matches += a.at("cross_matches").get<std::int64_t>();
      report->num_thinned_matches += a.at("thinned_matches").get<std::int64_t>();
      report->num_conflicting_matches += a.at("conflicting_matches").get<std::int64_t>();
      report->num_invalid_matches += a.at("invalid_matches").get<std::int64_t>();
      std::set<std::string> final_sessions;
      for (const int k : FinalSessions(steps, s)) final_sessions.insert(season.sessions[k]);
      for (const json& p : j.at("passes")) {
        const FusePassReport pr = PassReportFromJson(p);
        if (!final_sessions.count(pr.session)) continue;
        const auto it = season.index.find({pr.session, pr.pass});
        if (it == season.index.end()) continue;
        report->passes[it->second] = pr;
        if (p.contains("time_offset_s")) {
          result.time_offsets_s[it->second] = p.at("time_offset_s").get<double>();
        }
      }
      for (const StepCamera& camera : ReadStepCalibrations(dir, j)) {
        const std::string key = WrittenCameraKey(camera.calibration);
        if (!cameras_by_key.count(key)) camera_order.push_back(key);
        fusion::RefinedCalibration& merged = cameras_by_key[key];
        std::vector<int> passes = merged.passes;
        for (const std::string& text : camera.passes) {
          const std::size_t slash = text.find('/');
          const auto it = season.index.find({text.substr(0, slash), text.substr(slash + 1)});
          if (it != season.index.end()) passes.push_back(it->second);
        }
        merged = camera.calibration;
        std::sort(passes.begin(), passes.end());
        passes.erase(std::unique(passes.begin(), passes.end()), passes.end());
        merged.passes = passes;
      }
      for (const json& t : j.at("ground_ties")) ground_ties.push_back(t);
      step_list.push_back({{"session", j.at("session")},
                           {"folder", dir.filename().string()},
                           {"sweep", steps[s].sweep},
                           {"backward", steps[s].backward},
                           {"optimised", j.at("optimised")},
                           {"held", j.at("held")},
                           {"landmarks", j.at("joint").at("landmarks")},
                           {"observations", j.at("joint").at("observations")},
                           {"moved_m", j.value("moved_m", 0.0)},
                           {"seconds", j.at("seconds")}});
    });
  }
  for (const std::string& key : camera_order) result.calibrations.push_back(cameras_by_key[key]);
  result.summary = joint;
  report->joint = joint;
  report->calibrations = result.calibrations;

  // The fused cameras of every pass, from its session's poses.tum and camera.json.
  std::vector<std::vector<geometry::Rigid3>> cameras(num_passes);
  std::vector<workspace::FusedCamera> intrinsics(num_passes);
  for (const std::string& session : season.sessions) {
    std::unordered_map<Timestamp, geometry::Rigid3> poses;
    for (const io::StampedPose& pose : io::ReadTum(layout.FusedPoses(session).string())) {
      poses[pose.t] = pose.pose;
    }
    const workspace::FusedCamera camera =
        workspace::ReadFusedCamera(layout.FusedCamera(session).string());
    for (std::size_t p = 0; p < num_passes; ++p) {
      if (season.passes[p]->data.session != session) continue;
      intrinsics[p] = camera;
      for (const Timestamp t : season.passes[p]->data.times) {
        const auto it = poses.find(t);
        if (it == poses.end()) {
          throw InputError(layout.FusedPoses(session).string() + ": no pose at " +
                           std::to_string(t) + " (rerun `crop4d fuse --force`)");
        }
        cameras[p].push_back(it->second);
      }
    }
  }

  // landmarks.ply and the COLMAP model from the landmarks of every step, a step at a time (their
  // observations on the season's passes): the season's are never all in memory.
  if (options.write_colmap) {
    // The image names only: the rest of the measurements is dropped pass by pass.
    for (auto& pass : season.passes) {
      workspace::PassData data = workspace::LoadPassData(layout.root().string(), pass->data.session,
                                                         pass->data.pass, {.measurements = true});
      pass->data.measurements.camera = std::move(data.measurements.camera);
    }
  }
  SeasonLandmarkWriter writer(season.passes, cameras, intrinsics, options.write_colmap, layout);
  for (const FuseStep& step : steps) {
    if (!step.assembled) continue;
    const fs::path path = steps_dir / StepFolderName(step, season.sessions) / "landmarks.bin";
    StepLandmarks owned = ReadStepLandmarks(path);
    std::vector<int> to_season;
    for (const std::string& label : owned.passes) {
      const std::size_t slash = label.find('/');
      const auto it = season.index.find({label.substr(0, slash), label.substr(slash + 1)});
      if (it == season.index.end()) {
        throw InputError(path.string() + ": pass " + label +
                         " is not in the workspace (rerun `crop4d fuse --force`)");
      }
      to_season.push_back(it->second);
    }
    for (std::size_t l = 0; l < owned.landmarks.size(); ++l) {
      for (fusion::JointObservation& o : owned.landmarks[l].observations) {
        o.pass = to_season[o.pass];
        if (o.state < 0 || o.state >= static_cast<int>(cameras[o.pass].size())) {
          throw InputError(path.string() + ": observation of an image the pass does not have" +
                           " (rerun `crop4d fuse --force`)");
        }
      }
      writer.Add(owned.landmarks[l], owned.positions[l],
                 std::vector<bool>(owned.landmarks[l].observations.size(), true));
    }
  }
  writer.Finish();
  for (auto& pass : season.passes) pass->data.measurements.camera.reset();

  json summary = FuseSummaryJson(*report, result, stamp, options, season.sessions);
  summary["ground_ties"] = ground_ties;
  summary["steps"] = step_list;
  workspace::WriteSeasonQuality(layout.FusedQuality().string(), report->quality);
  workspace::RecordOutputs(&summary, layout.FusedDir(), workspace::FilesBelow(layout.FusedDir()));
  workspace::WriteFusedSummary(layout.FusedSummary().string(), summary);
}

}  // namespace

std::vector<FuseStep> PlanFuseSteps(int num_sessions, int window) {
  std::vector<FuseStep> steps;
  if (num_sessions <= 0) return steps;
  const int first_last = std::min(window, num_sessions - 1);
  steps.push_back({first_last, 0, -1});
  for (int k = first_last + 1; k < num_sessions; ++k) {
    steps.push_back({k, k - window, k - window - 1});
  }
  return steps;
}

std::vector<FuseStep> PlanFullFuseSteps(int num_sessions, int window, int rounds) {
  std::vector<FuseStep> steps = PlanFuseSteps(num_sessions, window);
  // The window that ends at session b, with the sessions on both sides held.
  const auto window_to = [&](int b, int sweep, bool backward) {
    FuseStep step;
    step.last = b;
    step.first = std::max(0, b - window);
    step.held = step.first - 1;
    step.held_after = b + 1 < num_sessions ? b + 1 : -1;
    step.sweep = sweep;
    step.backward = backward;
    step.assembled = false;
    return step;
  };
  const int first_last = std::min(window, num_sessions - 1);
  if (num_sessions - 1 <= first_last) return steps;  // one step: the season in one problem
  for (int r = 1; r <= rounds; ++r) {
    // Backward from the window before the last one solved to the first; forward again from the
    // window after the first to the last.
    for (int b = num_sessions - 2; b >= first_last; --b) steps.push_back(window_to(b, r, true));
    for (int b = first_last + 1; b < num_sessions; ++b) steps.push_back(window_to(b, r, false));
  }
  // The landmarks of the last round: its backward sweep's step at the season's start, then its
  // forward sweep (each window in date order, as the steps that add the sessions).
  for (FuseStep& step : steps)
    step.assembled = step.sweep == rounds && (!step.backward || step.first == 0);
  return steps;
}

std::string StepFolderName(const FuseStep& step, const std::vector<std::string>& sessions) {
  if (step.sweep == 0) return sessions[step.last];
  return "sweep" + std::to_string(step.sweep) + (step.backward ? "b-" : "f-") + sessions[step.last];
}

std::vector<int> FinalSessions(const std::vector<FuseStep>& steps, std::size_t s) {
  std::vector<int> sessions;
  for (int k = steps[s].first; k <= steps[s].last; ++k) {
    if (SourceStep(steps, steps.size(), k) == static_cast<int>(s)) sessions.push_back(k);
  }
  return sessions;
}

int SourceStep(const std::vector<FuseStep>& steps, std::size_t s, int session) {
  for (std::size_t t = s; t-- > 0;) {
    if (steps[t].first <= session && session <= steps[t].last) return static_cast<int>(t);
  }
  return -1;
}

FuseReport RunIncrementalFuse(SeasonPasses& season, const std::string& workspace,
                              const std::vector<fs::path>& association_files,
                              const FuseStageOptions& options) {
  const auto start = Clock::now();
  FuseReport report;
  report.num_sessions = static_cast<int>(season.sessions.size());
  report.num_passes = static_cast<int>(season.passes.size());
  const workspace::Layout layout(workspace);
  const SeasonIndex index = IndexSeason(season, association_files);
  const int num_sessions = static_cast<int>(season.sessions.size());
  const std::vector<FuseStep> steps =
      options.full ? PlanFullFuseSteps(num_sessions, options.window_sessions, options.full_sweeps)
                   : PlanFuseSteps(num_sessions, options.window_sessions);

  // Every step's fingerprint, chained; the season's is the last one's.
  std::vector<std::string> stamps;
  Fnv1aHasher season_stamp;
  season_stamp.AddString(options.full ? "full" : "incremental");
  for (const FuseStep& step : steps) {
    std::vector<bool> held;
    const std::vector<int> passes = StepPasses(index, step, &held);
    stamps.push_back(StepStamp(stamps.empty() ? std::string() : stamps.back(), step, season, index,
                               passes, held, StepAssociationFiles(season, index, passes, held),
                               options));
    season_stamp.AddString(stamps.back());
  }
  const std::string stamp = std::to_string(season_stamp.hash());
  if (!options.force && FusedUpToDate(layout, season.sessions, stamp)) {
    spdlog::info("fuse: up to date, skipped (--force to fuse again)");
    report.skipped = true;
    report.quality = ReadSeasonQuality(workspace);
    return report;
  }

  // Folders of steps that are not in this season, and outputs of the whole-season fuse, go.
  const fs::path steps_dir = layout.FusedStepsDir();
  std::set<std::string> step_names;
  for (const FuseStep& step : steps) step_names.insert(StepFolderName(step, season.sessions));
  if (fs::is_directory(steps_dir)) {
    for (const auto& entry : fs::directory_iterator(steps_dir)) {
      if (!step_names.count(entry.path().filename().string())) fs::remove_all(entry.path());
    }
  }
  fs::create_directories(steps_dir);

  // The grades of the sessions: a degraded session must not move the others.
  const std::vector<bool> protects = GradeSessions(season.passes, options, &report);
  const StepContext ctx{season, index, steps, protects, workspace, options, layout};
  bool rerun = options.force;  // a step after one that ran starts from new states: it runs too
  for (std::size_t s = 0; s < steps.size(); ++s) {
    const fs::path dir = steps_dir / StepFolderName(steps[s], season.sessions);
    std::string why;
    if (!rerun && StepUpToDate(dir, stamps[s], FinalSessions(steps, s), season, layout, &why)) {
      FuseStepReport skipped;
      skipped.session = season.sessions[steps[s].last];
      skipped.name = dir.filename().string();
      skipped.sweep = steps[s].sweep;
      skipped.skipped = true;
      report.steps.push_back(skipped);
      continue;
    }
    if (!why.empty() && !rerun) spdlog::info("fuse: step {} solved again: {}", s + 1, why);
    report.steps.push_back(RunStep(ctx, s, stamps[s], &report));
    rerun = true;
  }
  report.seconds = SecondsSince(start);  // the summary's total: the steps
  AssembleSeason(season, steps, stamp, options, layout, &report);
  report.seconds = SecondsSince(start);
  return report;
}

}  // namespace crop4d::pipeline::fuse
