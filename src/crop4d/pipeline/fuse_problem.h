#pragma once

// The fuse stage's joint problem over a list of loaded passes (internal to pipeline/fuse_*.cc):
// the landmark graph of the passes and their association files, the ground ties, the sessions'
// grades, the solve (degraded sessions registered onto the trusted ones; passes of earlier
// sessions held) and the fused cameras. The whole-season fuse (fuse_stage.cc) runs it once over
// every pass, the incremental fuse (fuse_incremental.h) once per step over a window of sessions.

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "crop4d/association/association_file.h"
#include "crop4d/fusion/cross_pass_tracks.h"
#include "crop4d/fusion/joint_optimiser.h"
#include "crop4d/pipeline/fuse_pass.h"
#include "crop4d/pipeline/fuse_stage.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::pipeline::fuse {

using PassList = std::vector<std::unique_ptr<LoadedPass>>;

// Changes whenever the stage's outputs for the same inputs change.
// 4: session by session unless fuse.full; 5: a step refines the calibration of its free passes.
inline constexpr int kFuseStageRevision = 5;

// The passes with a camera of every session of a workspace, in session and pass order, with
// only their summaries and row-SLAM poses loaded (LoadPassProblem loads the rest).
struct SeasonPasses {
  PassList passes;
  std::map<association::PassRef, int> index;
  // The sessions with at least one such pass, in field order.
  std::vector<std::string> sessions;
};

// Throws InputError when no pass has a camera (row SLAM has not run).
SeasonPasses ListSeasonPasses(const std::vector<std::string>& field_sessions,
                              const std::string& workspace);

// Whether fused/ holds every session's outputs, a readable summary with `stamp` and intact
// outputs (why not is logged).
bool FusedUpToDate(const workspace::Layout& layout, const std::vector<std::string>& sessions,
                   const std::string& stamp);

// A pair of passes of two sessions that an association file relates, with its cross matches.
using SessionPair = std::tuple<int, int, std::int64_t>;

// The joint landmarks over the passes with `use[p]` (fusion/cross_pass_tracks.h), each
// observation with its keypoint, each landmark with the mean colour of its keypoints.
std::vector<fusion::JointLandmark> JoinLandmarks(const fusion::CrossPassTracks& graph,
                                                 const PassList& passes,
                                                 const std::vector<bool>& use,
                                                 std::int64_t* num_conflicting);

// The landmark graph: each pass's landmarks, then the cross matches of `association_files`
// (thinned, stale ones counted and left out) with the cloud tracks they join. The pairs of
// passes of two sessions, with their number of cross matches, go to `session_pairs`; the
// association counts to `report`.
fusion::CrossPassTracks BuildLandmarkGraph(
    const PassList& passes, const std::map<association::PassRef, int>& pass_index,
    const std::vector<std::filesystem::path>& association_files, const FuseStageOptions& options,
    FuseReport* report, std::vector<SessionPair>* session_pairs);

// Ground ties (fusion/ground_ties.h) where appearance left two dates of a row without cross
// matches, unless both passes have a precise GPS (their reports to report->tie_pairs).
std::vector<fusion::JointGroundTie> GroundTies(const PassList& passes,
                                               const std::vector<SessionPair>& session_pairs,
                                               const FuseStageOptions& options, FuseReport* report);

// The grades of the sessions (season_quality.h, into report->quality; only the passes' summaries
// are read), and whether each pass belongs to a session that the others must not move.
std::vector<bool> GradeSessions(const PassList& passes, const FuseStageOptions& options,
                                FuseReport* report);

// The joint problem. Passes with `held[p]` (empty: none) keep their initial states and their
// calibration (a rig camera of their own; the free passes' copy is refined). With
// degraded sessions among the others (a free pass not `protects`ed), first the trusted passes
// alone, then every pass with the trusted ones held where that solve put them.
fusion::JointOptimiser::Result SolveJoint(const fusion::CrossPassTracks& graph,
                                          const PassList& passes,
                                          const std::vector<fusion::JointLandmark>& landmarks,
                                          const std::vector<fusion::JointGroundTie>& ties,
                                          const std::vector<bool>& protects,
                                          const std::vector<bool>& held,
                                          const FuseStageOptions& options);

// The calibrations of `result` that an earlier solve refined (and this one held there) reported
// as refined from the calibration as written (fusion::ReportRefinedCalibrations), and the count
// of refined cameras in its summary.
void ReportEarlierRefinement(const std::vector<fusion::RefinedCalibration>& earlier,
                             fusion::JointOptimiser::Result* result);

// The fused world_from_camera of every image of every pass, and each pass's correction against
// row SLAM (appended to report->passes).
std::vector<std::vector<geometry::Rigid3>> FusedCameras(
    const PassList& passes, const fusion::JointOptimiser::Result& result, FuseReport* report);

// The association files (<a>__<b>.bin) of a folder, sorted; none when it does not exist.
std::vector<std::filesystem::path> AssociationFiles(const std::filesystem::path& folder);

}  // namespace crop4d::pipeline::fuse
