// OMPL RRTConnect + FCL on a scene exported by `planner scenes --write` and flattened by
// run.py (see docs/ompl-comparison.md). Our own code; not part of the cargo workspace.
//
// Usage: ompl_solve SCENE.txt --seed N --time-limit S --step D --edge-resolution R
//        [--metric l2|sum] [--segments uniform|per-component] [--bench-checks N]
// Defaults: our metric (l2) and edges checked every R of it (uniform); see OursMetric.
// Prints one JSON object: solved, time_s, collision_checks, checks_per_s, us_per_check.
#include <fcl/fcl.h>
#include <ompl/base/PlannerData.h>
#include <ompl/base/ScopedState.h>
#include <ompl/base/spaces/SE2StateSpace.h>
#include <ompl/base/spaces/SE3StateSpace.h>
#include <ompl/geometric/SimpleSetup.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace ob = ompl::base;
namespace og = ompl::geometric;
using Obj = std::shared_ptr<fcl::CollisionObjectd>;

// The space as ours measures it. `l2` (default): our metric, sqrt(|Δp|² + (0.1 m·θ)²)
// (θ the rotation angle, rad), instead of OMPL's weighted sum |Δp| + 0.1·θ, so that
// nearest neighbours, the range and the edge resolution mean the same on both sides.
// Edges are validated every `resolution` of that metric, as ours are: OMPL's compound
// spaces count segments per component (translation and rotation apart, unweighted, at
// fraction × the component's extent) and take the maximum, which checks rotations about
// 5× more densely than ours (`--segments per-component` restores it).
template <class Base>
struct OursMetric : Base {
    bool l2 = true;
    double resolution = 0.005;  // weighted m; <= 0: OMPL's per-component count
    // Rotation angle θ (rad) of component 1: SO2 distance is θ, SO3's acos|q1·q2| is θ/2.
    double rot_factor = 1.0;
    double distance(const ob::State *a, const ob::State *b) const override {
        if (!l2) return Base::distance(a, b);
        // Like CompoundStateSpace::distance: the components' own (virtual) distances.
        auto *ca = a->as<ob::CompoundState>();
        auto *cb = b->as<ob::CompoundState>();
        double dp = this->components_[0]->distance(ca->components[0], cb->components[0]);
        double th = rot_factor * this->components_[1]->distance(ca->components[1], cb->components[1]);
        return std::sqrt(dp * dp + 0.01 * th * th);
    }
    unsigned int validSegmentCount(const ob::State *a, const ob::State *b) const override {
        if (resolution <= 0) return Base::validSegmentCount(a, b);
        return this->getValidSegmentCountFactor() *
               static_cast<unsigned int>(std::ceil(this->distance(a, b) / resolution));
    }
};

static std::shared_ptr<fcl::CollisionGeometryd> load_obj(const std::string &path, double scale) {
    std::ifstream in(path);
    if (!in) { std::cerr << "cannot open mesh " << path << "\n"; std::exit(2); }
    std::vector<fcl::Vector3d> v;
    std::vector<fcl::Triangle> t;
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream ls(line);
        std::string tag;
        ls >> tag;
        if (tag == "v") {
            double x, y, z;
            ls >> x >> y >> z;
            v.emplace_back(x * scale, y * scale, z * scale);
        } else if (tag == "f") {
            std::vector<int> idx;
            std::string tok;
            while (ls >> tok) idx.push_back(std::stoi(tok.substr(0, tok.find('/'))) - 1);
            for (size_t i = 1; i + 1 < idx.size(); ++i) t.emplace_back(idx[0], idx[i], idx[i + 1]);
        }
    }
    auto m = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
    m->beginModel();
    m->addSubModel(v, t);
    m->endModel();
    return m;
}

// Scene convention: Rz(yaw)·Ry(pitch)·Rx(roll), fixed axes.
static Eigen::Quaterniond rpy_quat(double roll, double pitch, double yaw) {
    return Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                              Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                              Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()));
}

struct Scene {
    bool planar = false;
    double lo[3], hi[3], start[3], goal[3];
    double start_rpy[3] = {0, 0, 0}, goal_rpy[3] = {0, 0, 0};  // rad, as the parts'
    std::vector<Obj> obstacles, moving;
    std::vector<fcl::Transform3d> moving_offset;  // part pose in the object frame
};

static Scene load_scene(const std::string &path) {
    std::ifstream in(path);
    if (!in) { std::cerr << "cannot open " << path << "\n"; std::exit(2); }
    Scene s;
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream ls(line);
        std::string tag;
        ls >> tag;
        if (tag == "space") { std::string sp; ls >> sp; s.planar = sp == "planar"; }
        else if (tag == "bounds") ls >> s.lo[0] >> s.lo[1] >> s.lo[2] >> s.hi[0] >> s.hi[1] >> s.hi[2];
        else if (tag == "start") ls >> s.start[0] >> s.start[1] >> s.start[2] >> s.start_rpy[0] >> s.start_rpy[1] >> s.start_rpy[2];
        else if (tag == "goal") ls >> s.goal[0] >> s.goal[1] >> s.goal[2] >> s.goal_rpy[0] >> s.goal_rpy[1] >> s.goal_rpy[2];
        else if (tag == "obs" || tag == "mov") {
            std::string shape;
            ls >> shape;
            std::shared_ptr<fcl::CollisionGeometryd> g;
            if (shape == "box") { double a, b, c; ls >> a >> b >> c; g = std::make_shared<fcl::Boxd>(2 * a, 2 * b, 2 * c); }
            else if (shape == "sphere") { double r; ls >> r; g = std::make_shared<fcl::Sphered>(r); }
            else if (shape == "mesh") { std::string f; double sc; ls >> f >> sc; g = load_obj(f, sc); }
            else { std::cerr << "unknown shape " << shape << "\n"; std::exit(2); }
            double x, y, z, roll = 0, pitch = 0, yaw = 0;
            ls >> x >> y >> z >> roll >> pitch >> yaw;
            fcl::Transform3d tf = fcl::Transform3d::Identity();
            tf.translation() = fcl::Vector3d(x, y, z);
            tf.linear() = rpy_quat(roll, pitch, yaw).toRotationMatrix();
            auto o = std::make_shared<fcl::CollisionObjectd>(g, tf);
            if (tag == "obs") s.obstacles.push_back(o);
            else { s.moving.push_back(o); s.moving_offset.push_back(tf); }
        }
    }
    return s;
}

static void set_rotation(ob::SO3StateSpace::StateType &r, const Eigen::Quaterniond &q) {
    r.w = q.w();
    r.x = q.x();
    r.y = q.y();
    r.z = q.z();
}

int main(int argc, char **argv) {
    if (argc < 2) { std::cerr << "usage: ompl_solve SCENE.txt [--seed N] [--time-limit S] [--step D] [--edge-resolution R] [--bench-checks N]\n"; return 2; }
    std::string scene_path = argv[1];
    unsigned long seed = 1;
    double time_limit = 10, step = 0.05, resolution = 0.005;
    long bench_checks = 0;
    bool per_component = false;  // --segments per-component: OMPL's own segment count
    bool sum_metric = false;     // --metric sum: OMPL's weighted sum (the weights below)
    for (int i = 2; i + 1 < argc; i += 2) {
        std::string k = argv[i];
        if (k == "--seed") seed = std::stoul(argv[i + 1]);
        else if (k == "--time-limit") time_limit = std::stod(argv[i + 1]);
        else if (k == "--step") step = std::stod(argv[i + 1]);
        else if (k == "--edge-resolution") resolution = std::stod(argv[i + 1]);
        else if (k == "--bench-checks") bench_checks = std::stol(argv[i + 1]);
        else if (k == "--segments") per_component = std::string(argv[i + 1]) == "per-component";
        else if (k == "--metric") sum_metric = std::string(argv[i + 1]) == "sum";
        else { std::cerr << "unknown option " << k << "\n"; return 2; }
    }
    ompl::msg::setLogLevel(ompl::msg::LOG_NONE);
    ompl::RNG::setSeed(seed);
    Scene sc = load_scene(scene_path);

    auto manager = std::make_shared<fcl::DynamicAABBTreeCollisionManagerd>();
    for (auto &o : sc.obstacles) manager->registerObject(o.get());
    manager->setup();

    ob::StateSpacePtr space;
    if (sc.planar) {
        auto se2 = std::make_shared<OursMetric<ob::SE2StateSpace>>();
        se2->resolution = per_component ? 0 : resolution;
        se2->l2 = !sum_metric;
        ob::RealVectorBounds b(2);
        for (int i = 0; i < 2; ++i) { b.setLow(i, sc.lo[i]); b.setHigh(i, sc.hi[i]); }
        se2->setBounds(b);
        // Ours: d² = |Δp|² + 0.01·θ²  →  OMPL SE2: |Δp| + 0.1·|Δθ|.
        se2->setSubspaceWeight(1, 0.1);
        space = se2;
    } else {
        auto se3 = std::make_shared<OursMetric<ob::SE3StateSpace>>();
        se3->resolution = per_component ? 0 : resolution;
        se3->l2 = !sum_metric;
        se3->rot_factor = 2.0;
        ob::RealVectorBounds b(3);
        for (int i = 0; i < 3; ++i) { b.setLow(i, sc.lo[i]); b.setHigh(i, sc.hi[i]); }
        se3->setBounds(b);
        // OMPL's SO3 distance is acos|q1·q2| = θ/2; weight 0.2 gives 0.1 m per rad as ours.
        se3->setSubspaceWeight(1, 0.2);
        space = se3;
    }
    og::SimpleSetup ss(space);
    std::atomic<long> checks{0};
    const double z0 = sc.start[2];
    auto valid = [&](const ob::State *st) -> bool {
        checks.fetch_add(1, std::memory_order_relaxed);
        fcl::Transform3d pose = fcl::Transform3d::Identity();
        if (sc.planar) {
            auto *s2 = st->as<ob::SE2StateSpace::StateType>();
            if (!space->satisfiesBounds(st)) return false;
            pose.translation() = fcl::Vector3d(s2->getX(), s2->getY(), z0);
            pose.linear() = Eigen::AngleAxisd(s2->getYaw(), Eigen::Vector3d::UnitZ()).toRotationMatrix();
        } else {
            auto *s3 = st->as<ob::SE3StateSpace::StateType>();
            if (!space->satisfiesBounds(st)) return false;
            const auto &r = s3->rotation();
            pose.translation() = fcl::Vector3d(s3->getX(), s3->getY(), s3->getZ());
            pose.linear() = Eigen::Quaterniond(r.w, r.x, r.y, r.z).toRotationMatrix();
        }
        for (size_t i = 0; i < sc.moving.size(); ++i) {
            auto &m = sc.moving[i];
            m->setTransform(pose * sc.moving_offset[i]);
            m->computeAABB();
            fcl::DefaultCollisionData<double> data;
            manager->collide(m.get(), &data, fcl::DefaultCollisionFunction<double>);
            if (data.result.isCollision()) return false;
        }
        return true;
    };
    ss.setStateValidityChecker(valid);
    // Segment length = fraction × maximum extent (in OMPL's metric), so this fraction
    // makes the longest unchecked segment `resolution` weighted metres.
    ss.getSpaceInformation()->setStateValidityCheckingResolution(resolution / space->getMaximumExtent());

    ob::ScopedState<> start(space), goal(space);
    if (sc.planar) {
        start->as<ob::SE2StateSpace::StateType>()->setXY(sc.start[0], sc.start[1]);
        start->as<ob::SE2StateSpace::StateType>()->setYaw(sc.start_rpy[2]);
        goal->as<ob::SE2StateSpace::StateType>()->setXY(sc.goal[0], sc.goal[1]);
        goal->as<ob::SE2StateSpace::StateType>()->setYaw(sc.goal_rpy[2]);
    } else {
        auto *a = start->as<ob::SE3StateSpace::StateType>();
        a->setXYZ(sc.start[0], sc.start[1], sc.start[2]);
        set_rotation(a->rotation(), rpy_quat(sc.start_rpy[0], sc.start_rpy[1], sc.start_rpy[2]));
        auto *g = goal->as<ob::SE3StateSpace::StateType>();
        g->setXYZ(sc.goal[0], sc.goal[1], sc.goal[2]);
        set_rotation(g->rotation(), rpy_quat(sc.goal_rpy[0], sc.goal_rpy[1], sc.goal_rpy[2]));
    }
    ss.setStartAndGoalStates(start, goal);
    auto planner = std::make_shared<og::RRTConnect>(ss.getSpaceInformation());
    planner->setRange(step);
    ss.setPlanner(planner);
    ss.setup();

    if (bench_checks > 0) {
        // Per-check cost alone: uniform random states, same checker.
        auto sampler = space->allocStateSampler();
        std::vector<ob::State *> states(bench_checks);
        for (auto &s : states) { s = space->allocState(); sampler->sampleUniform(s); }
        long n_valid = 0;
        auto t0 = std::chrono::steady_clock::now();
        for (auto *s : states) n_valid += valid(s);
        double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf("{\"bench_checks\":%ld,\"valid\":%ld,\"time_s\":%.6f,\"us_per_check\":%.4f}\n",
                    bench_checks, n_valid, dt, dt * 1e6 / bench_checks);
        for (auto *s : states) space->freeState(s);
        return 0;
    }

    checks = 0;
    auto t0 = std::chrono::steady_clock::now();
    ob::PlannerStatus st = ss.solve(time_limit);
    double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    bool solved = st == ob::PlannerStatus::EXACT_SOLUTION;
    long n = checks.load();
    ob::PlannerData data(ss.getSpaceInformation());
    planner->getPlannerData(data);
    std::printf("{\"solved\":%s,\"time_s\":%.6f,\"nodes\":%u,\"collision_checks\":%ld,\"checks_per_s\":%.1f,\"us_per_check\":%.4f,\"max_extent\":%.6f,\"segment_fraction\":%.8f}\n",
                solved ? "true" : "false", dt, data.numVertices(), n, n / dt, n > 0 ? dt * 1e6 / n : 0.0,
                space->getMaximumExtent(), resolution / space->getMaximumExtent());
    return 0;
}
