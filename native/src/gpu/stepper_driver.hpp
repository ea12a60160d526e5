// The GPU engine's run (docs/gpu.md): the driver (engine/run_driver.hpp)
// through which the CPU engine's run loop (engine/drum.cpp, run_drums;
// engine/box.cpp, run_box) steps its simulations on a GPU stepper
// (gpu/drum_gpu.hpp, gpu/box_gpu.hpp), one class for both scenes.
//
// Where the run loop asks for it, a member's state is downloaded into its
// simulation's store, in the order the stepper keeps (the simulation's after
// make_drum or make_box); nothing is downloaded between. Each step the
// stepper checks the move limit (Simulation::max_step_move); a step beyond it
// is reported by the CPU engine's own check (Simulation::report_unstable_step).
// The health check runs on the device as a screen (each replica's worst
// overlap and any non-finite value); where it finds one beyond the limit, the
// CPU engine's check runs on the downloaded state (a copy with a neighbour
// list of its own) and stops the run with its message. The Coulomb census is
// taken the same way, on a copy with its own list. Checkpoints hold the
// stepper's order and its neighbour list's reference positions, so a resumed
// run repeats the uninterrupted one bit for bit.
#pragma once
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "engine/checkpoint.hpp"
#include "engine/coulomb_census.hpp"
#include "engine/health.hpp"
#include "engine/run_driver.hpp"
#include "gpu/step_unstable.hpp"
#include "gpu/stepper.hpp"

namespace granular::gpu {

// Why the GPU engine does not run a scene of kind `kind` (scene.kind), or
// empty where it does: the one place that says which scenes it runs.
inline std::string unsupported_scene(const std::string& kind) {
  if (kind != "drum" && kind != "shaken_box")
    return "the GPU engine runs drum and shaken-box scenes only, not a " + kind + " scene";
  return "";
}

// The key a GPU run's checkpoint carries (CheckpointData::ints), which the
// CPU engine's lack: a run resumes on the engine that wrote its checkpoint.
inline constexpr const char* kCheckpointKey = "gpu_path";

// Kind, a scene's part of the driver (SceneKind):
//   SimVariant, Model, Stepper        DrumSim, DrumModel, DrumStepper (or the box's)
//   static Model model(const SimVariant&)                 the stepper's model of a simulation
//   template <class Sim> static void check(const Sim&, const HealthLimits&)
//                                     the CPU engine's health check of a state whose
//                                     neighbour list is current
template <class Kind>
using StepperFactoryOf =
    std::unique_ptr<typename Kind::Stepper> (*)(const std::vector<typename Kind::Model>&);

// The Kind of a scene whose simulations are the alternatives of Variant, its
// model made by ModelOf and stepped by a Stepper<Dim>, its health check
// Health{}(sim, limits).
template <class Variant, class ModelT, int Dim, ModelT (*ModelOf)(const Variant&), class Health>
struct SceneKind {
  using SimVariant = Variant;
  using Model = ModelT;
  using Stepper = gpu::Stepper<Dim>;
  static Model model(const Variant& sim) { return ModelOf(sim); }
  template <class Sim>
  static void check(const Sim& sim, const HealthLimits& lim) {
    Health{}(sim, lim);
  }
};

// The driver of sims[0..K) (one scene, K seeds; Sim: their alternative),
// stepped together as the replicas of one stepper from `make`. view: a
// simulation of the scene (the copy the health check and the census rebuild
// a list in). labels[r] names member r in the message of an instability when
// K > 1.
template <class Kind, class Sim>
class StepperDriver final : public RunDriver {
 public:
  using Variant = typename Kind::SimVariant;
  using Factory = StepperFactoryOf<Kind>;

  StepperDriver(Variant view, std::vector<Variant*> sims, Factory make, std::vector<std::string> labels)
      : sims_(std::move(sims)),
        make_(make),
        labels_(std::move(labels)),
        view_(std::move(view)),
        current_(sims_.size(), true),
        x_ref_(sims_.size()) {}

  void restore(std::size_t r, const CheckpointData& c) override {
    if (!c.ints.count(kCheckpointKey))
      throw std::runtime_error("the checkpoint was written by the CPU engine; resume it with --device cpu");
    x_ref_[r] = restore_state(sim(r), c);
    current_[r] = true;
  }

  void start() override {
    std::vector<typename Kind::Model> ms;
    for (std::size_t r = 0; r < sims_.size(); ++r) {
      auto m = Kind::model(*sims_[r]);
      m.x_ref = std::move(x_ref_[r]);
      ms.push_back(std::move(m));
    }
    stepper_ = make_(ms);
  }

  void advance(long n) override {
    try {
      stepper_->advance(n);
    } catch (const StepUnstable& e) {
      const std::size_t r = static_cast<std::size_t>(e.replica);
      Sim& v = sim(r);
      stepper_->download(v.p, e.replica);
      v.time = stepper_->time();
      v.step_count = stepper_->step_count();
      named(r, [&] { v.report_unstable_step(); });
    }
    for (std::size_t r = 0; r < sims_.size(); ++r) {
      sim(r).time = stepper_->time();
      sim(r).step_count = stepper_->step_count();
      current_[r] = false;
    }
  }

  void fetch(std::size_t r) override {
    if (current_[r]) return;
    stepper_->download(sim(r).p, static_cast<int>(r));
    current_[r] = true;
  }

  void check_health(const HealthLimits& lim) override {
    const std::vector<double> worst = stepper_->worst_overlap();
    for (std::size_t r = 0; r < sims_.size(); ++r) {
      if (worst[r] <= lim.max_overlap) continue;
      Sim& v = view_of(r);
      bool finite = true;
      for (std::size_t i = 0; i < v.p.size(); ++i)
        finite = finite && std::isfinite(v.p.x[i].squaredNorm() + v.p.v[i].squaredNorm() + v.p.w[i].squaredNorm());
      if (finite) v.rebuild();
      named(r, [&] { Kind::check(v, lim); });
    }
  }

  CoulombCensus census(std::size_t r) override {
    Sim& v = view_of(r);
    v.rebuild();
    return coulomb_census(v);
  }

  void capture(std::size_t r, CheckpointData& c) override {
    fetch(r);
    granular::capture(sim(r), c);
    c.reals["x_ref"] = ckpt_detail::flat(stepper_->reference_positions(static_cast<int>(r)));
    c.ints[kCheckpointKey] = {1};
  }

 private:
  Sim& sim(std::size_t r) { return std::get<Sim>(*sims_[r]); }

  // Member r's current state in the copy with a list of its own.
  Sim& view_of(std::size_t r) {
    fetch(r);
    Sim& v = std::get<Sim>(view_);
    v.p = sim(r).p;
    v.time = sim(r).time;
    v.step_count = sim(r).step_count;
    return v;
  }

  // f(), whose UnstableError names member r where there are several.
  template <class F>
  void named(std::size_t r, F&& f) {
    try {
      f();
    } catch (const UnstableError& e) {
      if (sims_.size() < 2 || r >= labels_.size()) throw;
      throw UnstableError(labels_[r] + ": " + e.what());
    }
  }

  std::vector<Variant*> sims_;
  Factory make_;
  std::vector<std::string> labels_;
  Variant view_;
  std::vector<bool> current_;  // the member's store holds its current state
  std::vector<Column<typename Sim::V>> x_ref_;  // restored members' list references
  std::unique_ptr<typename Kind::Stepper> stepper_;
};

// The driver of sims (one scene; view: a simulation of it), for their alternative.
template <class Kind>
std::unique_ptr<RunDriver> make_stepper_driver(typename Kind::SimVariant view,
                                               std::vector<typename Kind::SimVariant*> sims,
                                               StepperFactoryOf<Kind> make, std::vector<std::string> labels) {
  if (sims.empty()) throw std::invalid_argument("make_stepper_driver: no simulation");
  return std::visit(
      [&](auto& v) -> std::unique_ptr<RunDriver> {
        using Sim = std::decay_t<decltype(v)>;
        return std::make_unique<StepperDriver<Kind, Sim>>(std::move(view), std::move(sims), make, std::move(labels));
      },
      *sims.front());
}

}  // namespace granular::gpu
