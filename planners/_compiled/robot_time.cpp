// The robot-time objective of planners/ompl_objective.py (`RobotTimeObjective`), compiled: OMPL's planners
// call C++, not Python, for each motion's cost. Built by build.sh against the headers of the installed
// OMPL wheel's exact version and the nanobind release of that wheel (see README.md): nanobind then shares
// its type registry with the wheel's `_ompl` module, so this class is an `ompl.base.OptimizationObjective`
// to Python and its constructor takes the wheel's `SpaceInformation`.
#include <cmath>

#include <nanobind/nanobind.h>
#include <nanobind/stl/shared_ptr.h>

#include "ompl/base/OptimizationObjective.h"
#include "ompl/base/SpaceInformation.h"
#include "ompl/base/spaces/SE2StateSpace.h"
#include "ompl/config.h"

namespace nb = nanobind;
namespace ob = ompl::base;

namespace {

constexpr double kTau = 2.0 * M_PI;

// Robot time (s) of SE(2) motions: turn in place to the segment's heading, drive, turn to the second state's
// heading; no turn is charged leaving `start` or arriving at `goal` (positions in cm, headings free).
class RobotTimeObjectiveC : public ob::OptimizationObjective {
public:
    RobotTimeObjectiveC(const ob::SpaceInformationPtr &si, double s_per_cm, double s_per_rad, double stop_s,
                        double start_x, double start_y, double goal_x, double goal_y)
        : ob::OptimizationObjective(si), s_per_cm_(s_per_cm), s_per_rad_(s_per_rad), stop_s_(stop_s),
          start_x_(start_x), start_y_(start_y), goal_x_(goal_x), goal_y_(goal_y) {
        description_ = "Robot time (compiled)";
    }

    bool isSymmetric() const override { return false; }

    ob::Cost stateCost(const ob::State *) const override { return ob::Cost(0.0); }

    ob::Cost motionCost(const ob::State *s1, const ob::State *s2) const override {
        const auto *a = s1->as<ob::SE2StateSpace::StateType>();
        const auto *b = s2->as<ob::SE2StateSpace::StateType>();
        const double x1 = a->getX(), y1 = a->getY(), x2 = b->getX(), y2 = b->getY();
        const double dx = x2 - x1, dy = y2 - y1;
        const bool leaves_start = x1 == start_x_ && y1 == start_y_;
        const bool reaches_goal = x2 == goal_x_ && y2 == goal_y_;
        if (dx == 0.0 && dy == 0.0) {
            if (leaves_start || reaches_goal)
                return ob::Cost(0.0);
            return ob::Cost(std::fabs(std::remainder(b->getYaw() - a->getYaw(), kTau)) * s_per_rad_);
        }
        const double phi = std::atan2(dy, dx);
        double cost = std::hypot(dx, dy) * s_per_cm_;
        if (!leaves_start) {
            const double leave = std::fabs(std::remainder(phi - a->getYaw(), kTau));
            if (leave > 1e-9)
                cost += leave * s_per_rad_ + stop_s_;
        }
        if (!reaches_goal)
            cost += std::fabs(std::remainder(b->getYaw() - phi, kTau)) * s_per_rad_;
        return ob::Cost(cost);
    }

    ob::Cost motionCostHeuristic(const ob::State *s1, const ob::State *s2) const override {
        const auto *a = s1->as<ob::SE2StateSpace::StateType>();
        const auto *b = s2->as<ob::SE2StateSpace::StateType>();
        return ob::Cost(std::hypot(b->getX() - a->getX(), b->getY() - a->getY()) * s_per_cm_);
    }

private:
    double s_per_cm_, s_per_rad_, stop_s_, start_x_, start_y_, goal_x_, goal_y_;
};

}  // namespace

NB_MODULE(_robot_time, m) {
    nb::module_::import_("ompl.base");  // registers OptimizationObjective and SpaceInformation first
    m.attr("ompl_version") = OMPL_VERSION;  // the headers' version: the wheel's must be the same
    nb::class_<RobotTimeObjectiveC, ob::OptimizationObjective>(m, "RobotTimeObjectiveC")
        .def(nb::init<const ob::SpaceInformationPtr &, double, double, double, double, double, double, double>(),
             nb::arg("si"), nb::arg("s_per_cm"), nb::arg("s_per_rad"), nb::arg("stop_s"), nb::arg("start_x"),
             nb::arg("start_y"), nb::arg("goal_x"), nb::arg("goal_y"));
}
