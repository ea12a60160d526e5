#include "gpu/drum_run.hpp"

#include <cmath>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "engine/checkpoint.hpp"
#include "engine/coulomb_census.hpp"
#include "engine/health.hpp"
#include "gpu/drum_model.hpp"

namespace granular::gpu {

std::string unsupported_scene(const std::string& kind, const DrumScene* drum) {
  if (kind != "drum" || !drum) return "the GPU engine runs drum scenes only, not a " + kind + " scene";
  return "";
}

namespace {

template <class Sim>
class Driver final : public DrumDriver {
 public:
  Driver(const DrumScene& s, std::vector<DrumSim*> sims, StepperFactory make, std::vector<std::string> labels)
      : sims_(std::move(sims)),
        make_(make),
        labels_(std::move(labels)),
        view_(make_drum(s)),
        current_(sims_.size(), true),
        x_ref_(sims_.size()) {}

  void restore(std::size_t r, const CheckpointData& c) override {
    if (!c.ints.count(kCheckpointKey))
      throw std::runtime_error("the checkpoint was written by the CPU engine; resume it with --device cpu");
    x_ref_[r] = restore_state(sim(r), c);
    current_[r] = true;
  }

  void start() override {
    std::vector<DrumModel> ms;
    for (std::size_t r = 0; r < sims_.size(); ++r) {
      DrumModel m = drum_model(*sims_[r]);
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
      named(r, [&] { granular::check_health(v, lim); });
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

  std::vector<DrumSim*> sims_;
  StepperFactory make_;
  std::vector<std::string> labels_;
  DrumSim view_;
  std::vector<bool> current_;  // the member's store holds its current state
  std::vector<Column<Eigen::Vector3d>> x_ref_;  // restored members' list references
  std::unique_ptr<DrumStepper> stepper_;
};

}  // namespace

std::unique_ptr<DrumDriver> make_drum_driver(const DrumScene& s, std::vector<DrumSim*> sims, StepperFactory make,
                                             std::vector<std::string> labels) {
  if (sims.empty()) throw std::invalid_argument("make_drum_driver: no drum");
  const std::string why = unsupported_scene("drum", &s);
  if (!why.empty()) throw std::invalid_argument(why);
  return std::visit(
      [&](auto& v) -> std::unique_ptr<DrumDriver> {
        using Sim = std::decay_t<decltype(v)>;
        return std::make_unique<Driver<Sim>>(s, std::move(sims), make, std::move(labels));
      },
      *sims.front());
}

}  // namespace granular::gpu
