// vega_beam: the tetsim bench cantilever (issue 8's workload) run with VegaFEM, for a side-by-side
// timing against `tetsim bench`. Our own driver: it only calls VegaFEM's public API (built from
// VegaFEM's source, which is not part of this repository; see README.md).
//
// Usage: vega_beam MESH.node [frames] [newton_max_iterations]
//   MESH.node and MESH.ele: the TetGen files `tetsim mesh convert` writes (see run.sh).
//
// The scene, as tetsim's bench (src/bench.rs, scenes/bench/beam_n*.toml):
//   Neo-Hookean E = 1e6 Pa, nu = 0.3, density 1000 kg/m^3; the vertices at x = 0 fixed;
//   gravity (0, -9.81, 0) on the lumped masses; backward Euler, h = 1/30 s; Rayleigh stiffness
//   damping gamma = 0.01 s (no mass damping); Newton to 1e-4 of the step's first residual.
// VegaFEM's side: IsotropicHyperelasticFEM with Irving's inversion clamp (threshold 0.3, tetsim's
// stretch threshold) and Teran's SPD fix of the tangent (EnforceSPD), which the damping matrix
// also uses, as tetsim's default `damping_stiffness = "projected"`; ImplicitBackwardEulerSparse
// with its built-in Jacobi-preconditioned CG (relative tolerance 1e-6, at most 10,000 iterations:
// fixed inside VegaFEM), one thread.
//
// Prints one line per frame and a final line `RESULT {json}` for run.sh.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "CGSolver.h"
#include "generateMassMatrix.h"
#include "implicitBackwardEulerSparse.h"
#include "isotropicHyperelasticFEM.h"
#include "isotropicHyperelasticFEMForceModel.h"
#include "neoHookeanIsotropicMaterial.h"
#include "sparseMatrix.h"
#include "tetMesh.h"

namespace {

const double kYoungsModulus = 1.0e6;
const double kPoissonRatio = 0.3;
const double kDensity = 1000.0;
const double kGravity = -9.81;
const double kTimeStep = 1.0 / 30.0;
const double kRayleighStiffness = 0.01;
const double kNewtonTolerance = 1e-4;
const double kInversionThreshold = 0.3;

// CG solves and iterations, counted by the linker wrap of VegaFEM's Jacobi-preconditioned CG
// (see __wrap_ below): the integrator keeps its CG solver to itself and drops its return value.
long g_cg_solves = 0;
long g_cg_iterations = 0;
long g_cg_failures = 0;

double cpu_seconds() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

double wall_seconds() {
  using clock = std::chrono::steady_clock;
  return std::chrono::duration<double>(clock::now().time_since_epoch()).count();
}

// The next line of `in` that is not blank or a '#' comment.
bool data_line(std::ifstream &in, std::istringstream &line) {
  std::string text;
  while (std::getline(in, text)) {
    size_t hash = text.find('#');
    if (hash != std::string::npos) text.resize(hash);
    if (text.find_first_not_of(" \t\r") == std::string::npos) continue;
    line.clear();
    line.str(text);
    return true;
  }
  return false;
}

struct Mesh {
  std::vector<double> positions;  // 3 per vertex
  std::vector<int> tets;          // 4 per tet, 0-based
};

// TetGen .node/.ele as `tetsim mesh convert` writes them (indices 0- or 1-based, as the first
// vertex number in the .node says).
Mesh read_tetgen(const std::string &node_path) {
  std::string base = node_path.substr(0, node_path.size() - 5);
  std::ifstream node(node_path), ele(base + ".ele");
  if (!node || !ele) throw std::runtime_error("cannot open " + node_path + " and " + base + ".ele");
  Mesh mesh;
  std::istringstream line;
  int count = 0, dim = 0;
  if (!data_line(node, line) || !(line >> count >> dim) || dim != 3)
    throw std::runtime_error(node_path + ": bad header");
  int first = 0;
  for (int i = 0; i < count; i++) {
    int id;
    double x, y, z;
    if (!data_line(node, line) || !(line >> id >> x >> y >> z))
      throw std::runtime_error(node_path + ": bad vertex " + std::to_string(i));
    if (i == 0) first = id;
    mesh.positions.insert(mesh.positions.end(), {x, y, z});
  }
  int tets = 0, corners = 0;
  if (!data_line(ele, line) || !(line >> tets >> corners) || corners != 4)
    throw std::runtime_error(base + ".ele: bad header (linear tets only)");
  for (int t = 0; t < tets; t++) {
    int id, a, b, c, d;
    if (!data_line(ele, line) || !(line >> id >> a >> b >> c >> d))
      throw std::runtime_error(base + ".ele: bad tet " + std::to_string(t));
    for (int v : {a, b, c, d}) {
      if (v - first < 0 || v - first >= count)
        throw std::runtime_error(base + ".ele: tet " + std::to_string(t) + " has vertex out of range");
      mesh.tets.push_back(v - first);
    }
  }
  return mesh;
}

// VegaFEM's force model, counting the evaluations Newton makes (one per iteration plus the
// final convergence check).
class CountingForceModel : public ForceModel {
 public:
  explicit CountingForceModel(ForceModel *inner) : inner_(inner) { r = inner->Getr(); }
  void GetInternalForce(const double *u, double *f) override { inner_->GetInternalForce(u, f); }
  void GetTangentStiffnessMatrixTopology(SparseMatrix **k) override {
    inner_->GetTangentStiffnessMatrixTopology(k);
  }
  void GetTangentStiffnessMatrix(const double *u, SparseMatrix *k) override {
    inner_->GetTangentStiffnessMatrix(u, k);
  }
  void GetForceAndMatrix(const double *u, double *f, SparseMatrix *k) override {
    evaluations++;
    inner_->GetForceAndMatrix(u, f, k);
  }
  long evaluations = 0;

 private:
  ForceModel *inner_;
};

}  // namespace

// The linker wraps VegaFEM's CGSolver::SolveLinearSystemWithJacobiPreconditioner
// (-Wl,--wrap=<mangled name>, see CMakeLists.txt) so that its iterations can be counted; the
// member function is called with `this` first, as the x86-64 and AArch64 C++ ABIs pass it.
extern "C" int __real__ZN8CGSolver41SolveLinearSystemWithJacobiPreconditionerEPdPKddii(
    CGSolver *self, double *x, const double *b, double eps, int max_iterations, int verbose);
extern "C" int __wrap__ZN8CGSolver41SolveLinearSystemWithJacobiPreconditionerEPdPKddii(
    CGSolver *self, double *x, const double *b, double eps, int max_iterations, int verbose) {
  int result = __real__ZN8CGSolver41SolveLinearSystemWithJacobiPreconditionerEPdPKddii(
      self, x, b, eps, max_iterations, verbose);
  g_cg_solves++;
  g_cg_iterations += std::abs(result);
  if (result < 0) g_cg_failures++;
  return result;
}

int main(int argc, char **argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: %s MESH.node [frames=30] [newton_max_iterations=20]\n", argv[0]);
    return 2;
  }
  std::string node_path = argv[1];
  int frames = argc > 2 ? atoi(argv[2]) : 30;
  int newton_max = argc > 3 ? atoi(argv[3]) : 20;
  if (node_path.size() < 6 || node_path.substr(node_path.size() - 5) != ".node" || frames < 0 ||
      newton_max < 1) {
    fprintf(stderr, "%s: expected MESH.node, frames >= 0, newton_max_iterations >= 1\n", argv[0]);
    return 2;
  }

  double cpu0 = cpu_seconds(), wall0 = wall_seconds();
  Mesh mesh;
  try {
    mesh = read_tetgen(node_path);
  } catch (const std::exception &e) {
    fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  int vertices = (int)mesh.positions.size() / 3, tets = (int)mesh.tets.size() / 4, r = 3 * vertices;

  TetMesh tet_mesh(vertices, mesh.positions.data(), tets, mesh.tets.data(), kYoungsModulus,
                   kPoissonRatio, kDensity);
  NeoHookeanIsotropicMaterial material(&tet_mesh);
  IsotropicHyperelasticFEM fem(&tet_mesh, &material, kInversionThreshold, false);
  fem.EnforceSPD(true);
  IsotropicHyperelasticFEMForceModel vega_force_model(&fem);
  CountingForceModel force_model(&vega_force_model);

  // Lumped masses (row sums of the consistent mass matrix: rho V / 4 per tet corner), as tetsim.
  std::vector<double> masses(r);
  GenerateMassMatrix::computeVertexMasses(&tet_mesh, masses.data(), true);
  SparseMatrixOutline mass_outline(r, masses.data());
  SparseMatrix mass_matrix(&mass_outline);

  // Fixed: the vertices at x = 0 (the mesh's minimum x), all three DOFs, ascending.
  double x_min = 1e300, x_max = -1e300;
  for (int v = 0; v < vertices; v++) {
    x_min = std::min(x_min, mesh.positions[3 * v]);
    x_max = std::max(x_max, mesh.positions[3 * v]);
  }
  std::vector<int> fixed_dofs, tip;
  for (int v = 0; v < vertices; v++) {
    double x = mesh.positions[3 * v];
    if (x <= x_min + 1e-9) fixed_dofs.insert(fixed_dofs.end(), {3 * v, 3 * v + 1, 3 * v + 2});
    if (x >= x_max - 1e-9 * std::max(1.0, std::fabs(x_max))) tip.push_back(v);
  }

  ImplicitBackwardEulerSparse integrator(r, kTimeStep, &mass_matrix, &force_model,
                                         (int)fixed_dofs.size(), fixed_dofs.data(), 0.0,
                                         kRayleighStiffness, newton_max, kNewtonTolerance, 0);
  std::vector<double> gravity(r, 0.0);
  for (int v = 0; v < vertices; v++) gravity[3 * v + 1] = kGravity * masses[3 * v + 1];
  integrator.SetExternalForces(gravity.data());
  double setup_cpu = cpu_seconds() - cpu0, setup_wall = wall_seconds() - wall0;
  printf("vega_beam: %d vertices, %d tets, %zu fixed vertices, %zu tip vertices; setup %.3f s wall, "
         "%.3f s CPU\n",
         vertices, tets, fixed_dofs.size() / 3, tip.size(), setup_wall, setup_cpu);

  double run_cpu = 0, run_wall = 0;
  long newton_total = 0, unconverged = 0, failed = 0;
  for (int frame = 1; frame <= frames; frame++) {
    long solves0 = g_cg_solves, its0 = g_cg_iterations, evals0 = force_model.evaluations;
    double c = cpu_seconds(), w = wall_seconds();
    int status = integrator.DoTimestep();
    double frame_cpu = cpu_seconds() - c, frame_wall = wall_seconds() - w;
    run_cpu += frame_cpu;
    run_wall += frame_wall;
    long newton = g_cg_solves - solves0, cg = g_cg_iterations - its0;
    // A converged step evaluates once more than it solves (the final check); a step that hits
    // the iteration limit stops after its last solve.
    bool converged = status == 0 && force_model.evaluations - evals0 == newton + 1;
    newton_total += newton;
    unconverged += !converged;
    failed += status != 0;
    printf("frame %d: %.4f s wall, %.4f s CPU, %ld Newton, %ld CG (%.1f per Newton)%s\n", frame,
           frame_wall, frame_cpu, newton, cg, newton ? (double)cg / newton : 0.0,
           converged ? "" : (status ? ", CG FAILED" : ", NOT CONVERGED"));
    fflush(stdout);
  }

  const double *q = integrator.Getq();
  double mean[3] = {0, 0, 0};
  for (int v : tip)
    for (int k = 0; k < 3; k++) mean[k] += q[3 * v + k] / tip.size();
  double tip_norm = std::sqrt(mean[0] * mean[0] + mean[1] * mean[1] + mean[2] * mean[2]);
  int n = frames > 0 ? frames : 1;
  printf("RESULT {\"vertices\": %d, \"tets\": %d, \"frames\": %d, \"setup_wall_s\": %.6f, "
         "\"setup_cpu_s\": %.6f, \"wall_per_frame_s\": %.6f, \"cpu_per_frame_s\": %.6f, "
         "\"newton_per_frame\": %.4f, \"cg_per_newton\": %.2f, \"unconverged_frames\": %ld, "
         "\"cg_failures\": %ld, \"tip\": [%.9f, %.9f, %.9f], \"tip_norm\": %.9f}\n",
         vertices, tets, frames, setup_wall, setup_cpu, run_wall / n, run_cpu / n,
         (double)newton_total / n, newton_total ? (double)g_cg_iterations / newton_total : 0.0,
         unconverged, g_cg_failures, mean[0], mean[1], mean[2], tip_norm);
  return failed ? 1 : 0;
}
