// mesh_check - independent topology oracle for lodpipe's tests, built on OpenMesh only.
//
//   mesh_check FILE.obj      prints one JSON line:
//   {"faces":F,"vertices_used":V,"manifold":bool,"faces_refused":R,"faces_degenerate":D,
//    "nonmanifold_vertices":N,"boundary_loops":B,"euler":X,
//    "components":[{"faces":..,"vertices":..,"edges":..,"euler":V-E+F,"boundary_loops":..},...]}
//
// Nothing here comes from lodpipe's src/: the OBJ is read by the few lines below (v and f only;
// "f a/b/c" and negative indices accepted, polygons fan-triangulated), every face goes through
// OpenMesh's TriMesh::add_face, and all counts come from OpenMesh's own connectivity:
//  - faces_refused:     add_face returned an invalid handle (complex edge / complex vertex /
//                       patch re-linking failed: a non-manifold or inconsistently oriented face),
//                       also after retrying every refused face once the others are in (so the
//                       verdict does not depend on the order of the faces);
//  - faces_degenerate:  a face naming one vertex twice (never handed to OpenMesh);
//  - nonmanifold_vertices: vertices with faces for which OpenMesh's is_manifold() is false;
//  - components:        flood fill over OpenMesh face-face adjacency (faces sharing an edge);
//                       V, E, F counted over the component's faces, euler = V - E + F;
//  - boundary loops:    cycles of OpenMesh boundary halfedges, followed with next_halfedge;
//                       a loop is attributed to the component of the face across its first
//                       halfedge.
// Vertices no face references (isolated, e.g. a shared LOD vertex buffer) are left out.
// manifold = no refused, no degenerate faces and no non-manifold vertex.
// Exit status 0 on success, 1 if the file cannot be read or a face index is out of range
// (then {"error":...} is printed).
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

typedef OpenMesh::TriMesh_ArrayKernelT<> Mesh;

static int fail(const std::string& msg) {
  std::string o;
  for (char c : msg) {
    if (c == '"' || c == '\\') o += '\\';
    o += (unsigned char)c < 0x20 ? ' ' : c;
  }
  std::printf("{\"error\":\"%s\"}\n", o.c_str());
  return 1;
}

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: mesh_check FILE.obj\n");
    return 2;
  }
  std::ifstream in(argv[1]);
  if (!in) return fail(std::string("cannot open ") + argv[1]);

  // --- own OBJ parsing: v and f lines only -------------------------------------------------
  size_t nv = 0;
  std::vector<std::vector<long>> polys;
  std::string line;
  size_t lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    std::istringstream ls(line);
    std::string tag;
    if (!(ls >> tag)) continue;
    if (tag == "v") {
      ++nv;  // positions do not matter for topology
    } else if (tag == "f") {
      std::vector<long> p;
      std::string tok;
      while (ls >> tok) {
        const std::string head = tok.substr(0, tok.find('/'));
        char* end = nullptr;
        long i = std::strtol(head.c_str(), &end, 10);
        if (head.empty() || *end != '\0' || i == 0)
          return fail("line " + std::to_string(lineno) + ": bad face index '" + tok + "'");
        if (i < 0) i = long(nv) + i;  // relative index: -1 is the last vertex so far
        else i = i - 1;
        if (i < 0 || size_t(i) >= nv)
          return fail("line " + std::to_string(lineno) + ": face index " + head + " out of range");
        p.push_back(i);
      }
      if (p.size() < 3) return fail("line " + std::to_string(lineno) + ": face with fewer than 3 vertices");
      polys.push_back(p);
    }
  }

  // --- OpenMesh: add every face with add_face ----------------------------------------------
  omerr().disable();  // add_face reports "complex edge" etc. on omerr; we count instead
  Mesh mesh;
  std::vector<Mesh::VertexHandle> vh(nv);      // created lazily: isolated vertices never enter
  std::vector<char> used(nv, 0);
  size_t faces = 0, refused = 0, degenerate = 0;
  std::vector<std::array<long, 3>> retry;
  for (const auto& p : polys) {
    for (size_t k = 1; k + 1 < p.size(); ++k) {  // fan triangulation (lodpipe writes triangles)
      const long t[3] = {p[0], p[k], p[k + 1]};
      ++faces;
      for (long i : t) used[i] = 1;
      if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) {
        ++degenerate;
        continue;
      }
      for (long i : t)
        if (!vh[i].is_valid()) vh[i] = mesh.add_vertex(Mesh::Point(0, 0, 0));
      Mesh::FaceHandle f = mesh.add_face(vh[t[0]], vh[t[1]], vh[t[2]]);
      if (!f.is_valid()) retry.push_back({t[0], t[1], t[2]});
    }
  }
  // Refused faces are retried until no more can be added, so the verdict does not depend on
  // the order of the faces in the file; what is still refused then is a real complex edge/vertex.
  for (bool progress = true; progress && !retry.empty();) {
    progress = false;
    std::vector<std::array<long, 3>> again;
    for (const auto& t : retry) {
      if (mesh.add_face(vh[t[0]], vh[t[1]], vh[t[2]]).is_valid()) progress = true;
      else again.push_back(t);
    }
    retry.swap(again);
  }
  refused = retry.size();
  size_t vertices_used = 0;
  for (char u : used) vertices_used += u;

  size_t nonmanifold = 0;
  for (auto v : mesh.vertices())
    if (!mesh.is_isolated(v) && !mesh.is_manifold(v)) ++nonmanifold;

  // --- components: flood fill over face-face adjacency --------------------------------------
  std::vector<int> comp(mesh.n_faces(), -1);
  struct Comp {
    size_t faces = 0, vertices = 0, edges = 0, loops = 0;
  };
  std::vector<Comp> comps;
  std::vector<int> vmark(mesh.n_vertices(), -1), emark(mesh.n_edges(), -1);
  std::vector<Mesh::FaceHandle> stack;
  for (auto f0 : mesh.faces()) {
    if (comp[f0.idx()] >= 0) continue;
    const int c = int(comps.size());
    comps.emplace_back();
    Comp& C = comps.back();
    comp[f0.idx()] = c;
    stack.assign(1, f0);
    while (!stack.empty()) {
      Mesh::FaceHandle f = stack.back();
      stack.pop_back();
      ++C.faces;
      for (auto v : mesh.fv_range(f))
        if (vmark[v.idx()] != c) { vmark[v.idx()] = c; ++C.vertices; }
      for (auto e : mesh.fe_range(f))
        if (emark[e.idx()] != c) { emark[e.idx()] = c; ++C.edges; }
      for (auto g : mesh.ff_range(f))
        if (comp[g.idx()] < 0) { comp[g.idx()] = c; stack.push_back(g); }
    }
  }

  // --- boundary loops: walk boundary halfedges with next_halfedge -------------------------
  std::vector<char> hseen(mesh.n_halfedges(), 0);
  size_t loops = 0;
  for (auto h0 : mesh.halfedges()) {
    if (hseen[h0.idx()] || !mesh.is_boundary(h0)) continue;
    const Mesh::FaceHandle across = mesh.face_handle(mesh.opposite_halfedge_handle(h0));
    if (!across.is_valid()) continue;  // edge of no face (cannot happen: no isolated edges are made)
    ++loops;
    comps[comp[across.idx()]].loops++;
    Mesh::HalfedgeHandle h = h0;
    size_t guard = 0;
    do {
      hseen[h.idx()] = 1;
      h = mesh.next_halfedge_handle(h);
    } while (h != h0 && !hseen[h.idx()] && ++guard <= mesh.n_halfedges());
  }

  // --- output -------------------------------------------------------------------------------
  std::sort(comps.begin(), comps.end(), [](const Comp& a, const Comp& b) {
    if (a.faces != b.faces) return a.faces > b.faces;
    if (a.vertices != b.vertices) return a.vertices > b.vertices;
    return a.loops > b.loops;
  });
  long euler_total = 0;
  std::string cs;
  for (const Comp& C : comps) {
    const long euler = long(C.vertices) - long(C.edges) + long(C.faces);
    euler_total += euler;
    char b[160];
    std::snprintf(b, sizeof b, "%s{\"faces\":%zu,\"vertices\":%zu,\"edges\":%zu,\"euler\":%ld,\"boundary_loops\":%zu}",
                  cs.empty() ? "" : ",", C.faces, C.vertices, C.edges, euler, C.loops);
    cs += b;
  }
  const bool manifold = refused == 0 && degenerate == 0 && nonmanifold == 0;
  std::printf(
      "{\"faces\":%zu,\"vertices_used\":%zu,\"manifold\":%s,\"faces_refused\":%zu,\"faces_degenerate\":%zu,"
      "\"nonmanifold_vertices\":%zu,\"boundary_loops\":%zu,\"euler\":%ld,\"components\":[%s]}\n",
      faces, vertices_used, manifold ? "true" : "false", refused, degenerate, nonmanifold, loops, euler_total,
      cs.c_str());
  return 0;
}
