// Mesquite FeasibleNewton timing driver (for the meshsmooth side-by-side table).
//
// usage: mq_driver MESH.vtk [-v] [-o OUT.vtk]
//
// Objective: IdealWeightInverseMeanRatio under LPtoPTemplate(metric, 1) divided
// by the number of evaluated elements (set_dividing_by_n), FeasibleNewton on a
// global patch, skin vertices fixed (mark_skin_fixed) plus the VTK point scalar
// `fixed` (MeshImpl::read_vtk reads it).  Stops at |grad F|_2 < 1e-6 or 100
// iterations.  Planar 2-D meshes get an XYPlanarDomain (see below).
//
// stdout: one line "iterations seconds F_all_elements", where seconds is the
// wall time of InstructionQueue::run_instructions (Mesquite's own setup
// included, file reading excluded) and F_all_elements is the mean of the
// metric over ALL elements after the solve (Mesquite's internal F only counts
// elements that touch a free vertex).  -v prints details to stderr.

#include <cstdlib>
#include "Mesquite.hpp"
#include "Mesquite_MeshImpl.hpp"
#include "Mesquite_MsqError.hpp"
#include "Mesquite_Vector3D.hpp"
#include "Mesquite_MsqVertex.hpp"
#include "Mesquite_InstructionQueue.hpp"
#include "Mesquite_PatchData.hpp"
#include "Mesquite_TerminationCriterion.hpp"
#include "Mesquite_IdealWeightInverseMeanRatio.hpp"
#include "Mesquite_LPtoPTemplate.hpp"
#include "Mesquite_FeasibleNewton.hpp"
#include "Mesquite_XYPlanarDomain.hpp"
#include "Mesquite_TopologyInfo.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <vector>

using namespace Mesquite;

static double mean_over_elements(Mesh* mesh, MeshDomain* dom, QualityMetric& qm,
                                 bool free_only, size_t& count, MsqError& err)
{
  PatchData pd;
  pd.set_mesh(mesh);
  pd.set_domain(dom);
  pd.fill_global_patch(err);
  if (err) return NAN;
  std::vector<size_t> handles;
  qm.get_evaluations(pd, handles, free_only, err);
  if (err) return NAN;
  double sum = 0.0;
  for (size_t i = 0; i < handles.size(); ++i) {
    double v;
    bool ok = qm.evaluate(pd, handles[i], v, err);
    if (err) return NAN;
    if (!ok) { std::cerr << "warning: invalid element " << handles[i] << "\n"; }
    sum += v;
  }
  count = handles.size();
  return count ? sum / count : NAN;
}

int main(int argc, char** argv)
{
  const char* in = 0;
  const char* out = 0;
  bool verbose = false;
  int max_iter = 100;
  for (int i = 1; i < argc; ++i) {
    if (!strcmp(argv[i], "-v")) verbose = true;
    else if (!strcmp(argv[i], "-o") && i + 1 < argc) out = argv[++i];
    else if (!strcmp(argv[i], "-n") && i + 1 < argc) max_iter = atoi(argv[++i]);
    else in = argv[i];
  }
  if (!in || max_iter < 1) {
    std::cerr << "usage: " << argv[0] << " MESH.vtk [-v] [-o OUT.vtk] [-n MAX_ITERATIONS (100)]\n";
    return 2;
  }

  MsqPrintError err(std::cerr);
  MeshImpl mesh;
  mesh.read_vtk(in, err);                 // applies the `fixed` point scalar if present
  if (err) return 1;
  mesh.mark_skin_fixed(err, false);       // add skin, keep `fixed` from the file
  if (err) return 1;

  std::vector<Mesh::VertexHandle> verts;
  std::vector<Mesh::ElementHandle> elems;
  mesh.get_all_vertices(verts, err); if (err) return 1;
  mesh.get_all_elements(elems, err); if (err) return 1;
  std::vector<bool> fixed;
  mesh.vertices_get_fixed_flag(verts.empty() ? 0 : &verts[0], fixed, verts.size(), err);
  if (err) return 1;
  size_t nfixed = 0;
  for (size_t i = 0; i < fixed.size(); ++i) nfixed += fixed[i];

  // 2-D (surface) elements need a domain for the normal: use the mesh plane,
  // oriented along the summed element normals.
  std::vector<EntityTopology> types(elems.size());
  mesh.elements_get_topologies(elems.empty() ? 0 : &elems[0], types.empty() ? 0 : &types[0],
                               elems.size(), err);
  if (err) return 1;
  bool surface = false;
  for (size_t i = 0; i < types.size(); ++i)
    if (TopologyInfo::dimension(types[i]) == 2) surface = true;
  // Mesquite's FeasibleNewton accepts surface meshes only with an
  // XYPlanarDomain (plane z = 0, normal +z; it refuses anything else).  A mesh
  // in a plane z = c is shifted to z = 0, and a mesh whose elements face -z is
  // mirrored (y -> -y); both leave every element's quality unchanged and are
  // undone before writing -o.  Done before the timed call.
  XYPlanarDomain xyplane;
  MeshDomain* domain = 0;
  double zshift = 0.0, ysign = 1.0;
  if (surface) {
    std::vector<Mesh::VertexHandle> ev;
    std::vector<size_t> offs;
    mesh.elements_get_attached_vertices(&elems[0], elems.size(), ev, offs, err);
    if (err) return 1;
    std::vector<MsqVertex> c(ev.size());
    mesh.vertices_get_coordinates(&ev[0], &c[0], ev.size(), err);
    if (err) return 1;
    Vector3D nsum(0, 0, 0);
    for (size_t e = 0; e + 1 < offs.size(); ++e) {
      size_t b = offs[e], n = offs[e + 1] - offs[e];
      if (n < 3 || TopologyInfo::dimension(types[e]) != 2) continue;
      for (size_t k = 0; k < n; ++k)  // Newell normal of the polygon
        nsum += c[b + k] * c[b + (k + 1) % n];
    }
    Vector3D nrm = nsum / nsum.length();
    std::vector<MsqVertex> vc(verts.size());
    mesh.vertices_get_coordinates(&verts[0], &vc[0], verts.size(), err);
    if (err) return 1;
    double zmin = vc[0][2], zmax = vc[0][2], ext = 0.0;
    for (size_t i = 0; i < vc.size(); ++i) {
      zmin = std::min(zmin, vc[i][2]);
      zmax = std::max(zmax, vc[i][2]);
      ext = std::max(ext, (vc[i] - vc[0]).length());
    }
    if (std::fabs(std::fabs(nrm[2]) - 1.0) > 1e-9 || zmax - zmin > 1e-9 * (ext > 0 ? ext : 1.0)) {
      std::cerr << "error: surface mesh is not in a plane z = const (normal " << nrm[0] << " "
                << nrm[1] << " " << nrm[2] << ", z range " << zmin << ".." << zmax
                << "); Mesquite's FeasibleNewton only handles XYPlanarDomain surfaces\n";
      return 1;
    }
    zshift = -vc[0][2];
    ysign = nrm[2] > 0 ? 1.0 : -1.0;
    if (zshift != 0.0 || ysign < 0.0) {
      for (size_t i = 0; i < vc.size(); ++i) {
        Vector3D p(vc[i][0], ysign * vc[i][1], 0.0);
        mesh.vertex_set_coordinates(verts[i], p, err);
        if (err) return 1;
      }
    }
    domain = &xyplane;
    if (verbose)
      std::cerr << "planar: normal " << nrm[0] << " " << nrm[1] << " " << nrm[2]
                << ", z shift " << zshift << ", mirror y " << (ysign < 0) << "\n";
  }

  IdealWeightInverseMeanRatio metric(err);
  if (err) return 1;
  LPtoPTemplate obj(&metric, 1, err);
  if (err) return 1;
  obj.set_dividing_by_n(true);

  FeasibleNewton fn(&obj);
  fn.use_global_patch();
  TerminationCriterion tc_inner, tc_outer;
  tc_inner.add_absolute_gradient_L2_norm(1e-6);
  // -n caps the run: the timing of a run stopped at a given iteration
  tc_inner.add_iteration_limit(max_iter);
  tc_outer.add_iteration_limit(1);
  fn.set_inner_termination_criterion(&tc_inner);
  fn.set_outer_termination_criterion(&tc_outer);

  InstructionQueue q;
  q.set_master_quality_improver(&fn, err);
  if (err) return 1;
  MeshDomainAssoc mda(&mesh, domain);

  double F0_all = NAN;
  size_t n_all = 0, n_free = 0;
  if (verbose) F0_all = mean_over_elements(&mesh, domain, metric, false, n_all, err);
  if (err) return 1;

  auto t0 = std::chrono::steady_clock::now();
  q.run_instructions(&mda, err);
  auto t1 = std::chrono::steady_clock::now();
  if (err) return 1;
  double secs = std::chrono::duration<double>(t1 - t0).count();

  double F_all = mean_over_elements(&mesh, domain, metric, false, n_all, err);
  if (err) return 1;
  double F_free = mean_over_elements(&mesh, domain, metric, true, n_free, err);
  if (err) return 1;

  if (verbose) {
    fprintf(stderr,
            "%s: %zu vertices (%zu fixed), %zu elements (%zu touch a free vertex)%s\n"
            "F_all %.9f -> %.9f; Mesquite's own F (free-touching mean) %.9f (tc reports %.9f)\n",
            in, verts.size(), nfixed, elems.size(), n_free, surface ? ", planar" : "",
            F0_all, F_all, F_free, tc_inner.get_current_function_value());
  }
  if (out) {
    if (zshift != 0.0 || ysign < 0.0) {
      std::vector<MsqVertex> vc(verts.size());
      mesh.vertices_get_coordinates(&verts[0], &vc[0], verts.size(), err);
      if (err) return 1;
      for (size_t i = 0; i < vc.size(); ++i) {
        Vector3D p(vc[i][0], ysign * vc[i][1], vc[i][2] - zshift);
        mesh.vertex_set_coordinates(verts[i], p, err);
        if (err) return 1;
      }
    }
    mesh.write_vtk(out, err);
    if (err) return 1;
  }

  printf("%d %.6f %.9f\n", tc_inner.get_iteration_count(), secs, F_all);
  return 0;
}
