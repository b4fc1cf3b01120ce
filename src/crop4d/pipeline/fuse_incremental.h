#pragma once

// The incremental 4D fusion (DESIGN.md §2.4; the default of `crop4d fuse`, fuse_stage.h): the
// season fused session by session in date order, so that adding a session costs a bounded amount
// of work and memory instead of a rebuild of one problem over every pass of the season.
//
// The step that adds session k solves one joint problem (fuse_problem.h) over the passes of
// sessions k − W … k (W = FuseStageOptions::window_sessions), started where the previous step left
// the earlier ones and from row SLAM for session k, with the passes of session k − W − 1 held
// where the previous step put them: they anchor the window through the cross matches they share
// with it (association pairs a session with the next one). The first step fuses sessions 0 … W
// together. The calibration a step refined is carried to the next (a camera with a held pass is
// held). Session s is final after step s + W (or the last step), which writes its outputs.
// With FuseStageOptions::full, refinement sweeps follow (PlanFullFuseSteps): every window again,
// backward then forward, with the sessions on both sides held, so that the whole season is
// re-optimised a window at a time.
//
// Files of the step that added session k, in WS/fused/steps/<session k>/ (written in a temporary
// folder and renamed):
//   step.json      its fingerprint (chained: the previous step's, this step's passes, their
//                  association files, the options), the sessions optimised and held, the
//                  correction and time offset of every optimised pass, the rig's cameras, the
//                  joint problem's counts and the outputs it wrote (checked before it is skipped);
//   states/<session>__<pass>.csv   the full states of every optimised pass (the next step starts
//                  from them; workspace/pass_files.h);
//   camera-<i>.json, camera-<i>-written.json   each rig camera after the step and as written
//                  (workspace/fused_camera.h);
//   landmarks.bin  the landmarks that have an observation in session k (every landmark in the
//                  first step), with the observations the solve kept (format in the .cc).
// A step whose fingerprint and files are unchanged is not solved again: when a session is added
// at the end of the season, only its step runs. The season's outputs are those of fuse_stage.h:
// fused/<session>/ from the step that made the session final, landmarks.ply and colmap/ from
// every step's landmarks, summary.json with the steps ("steps") and their joint problems summed
// ("joint").

#include <filesystem>
#include <string>
#include <vector>

#include "crop4d/pipeline/fuse_problem.h"
#include "crop4d/pipeline/fuse_stage.h"

namespace crop4d::pipeline::fuse {

// One step: the session index it adds or, in a sweep, the last it optimises (`last`), the first
// session it optimises, and the sessions held before and after them (-1: none).
struct FuseStep {
  int last = 0;
  int first = 0;
  int held = -1;
  int held_after = -1;
  // 0: a step that adds session `last`; r >= 1: a step of the r-th round of refinement sweeps of
  // the full fuse, backward (from the season's end to its start) or forward.
  int sweep = 0;
  bool backward = false;
  // Whether the season's landmarks.ply and COLMAP model take this step's landmarks (those whose
  // latest session is `last`, or any session up to `last` when `first` is 0): the steps that
  // last solved each session's window in date order.
  bool assembled = true;
};

// The steps over `num_sessions` sessions with a window of `window` earlier sessions.
std::vector<FuseStep> PlanFuseSteps(int num_sessions, int window);

// The full re-optimisation (FuseStageOptions::full): the steps of PlanFuseSteps, then `rounds`
// rounds of two refinement sweeps — backward over the same windows (from the one before the
// last to the first), then forward again (from the second to the last) — each window solved with
// the session before it and the session after it held where the latest step left them. Every
// step holds at most window + 3 sessions, so the memory does not grow with the season; each
// session's result answers to the sessions on both sides of it.
std::vector<FuseStep> PlanFullFuseSteps(int num_sessions, int window, int rounds);

// The folder of a step in WS/fused/steps/: the session it adds, or for a sweep's step
// "sweep<r><b|f>-<last session>".
std::string StepFolderName(const FuseStep& step, const std::vector<std::string>& sessions);

// The sessions whose result step `s` of `steps` makes final (the step's outputs): those that no
// later step optimises.
std::vector<int> FinalSessions(const std::vector<FuseStep>& steps, std::size_t s);

// The latest step before `s` that optimised `session` (-1: none; its passes start from row SLAM).
int SourceStep(const std::vector<FuseStep>& steps, std::size_t s, int session);

FuseReport RunIncrementalFuse(SeasonPasses& season, const std::string& workspace,
                              const std::vector<std::filesystem::path>& association_files,
                              const FuseStageOptions& options);

}  // namespace crop4d::pipeline::fuse
