// wbc.constraints.narrow_phase: the narrow phase of wbc.constraints.self_collision in one call: coal distances of a list of geometry pairs at the
// joint placements of one configuration, written to one buffer.
//
// The Python path (pin.updateGeometryPlacements, pin.computeDistances, then one bound call per distance, witness
// point and normal read back) spends about as long in the bindings as in coal's GJK. This module owns its own coal
// geometries (the same shapes: the convex hull of a mesh is rebuilt here by coal from the same vertices with the
// same qhull command, as BVHModelBase::buildConvexHull does) and one coal::ComputeDistance functor per pair, as
// pinocchio::GeometryData does (its GJK solver keeps the pair's guess from one call to the next), with the request
// pinocchio::GeometryData builds (DistanceRequest(true), enable_cached_gjk_guess) and the caller's GJK tolerance.
// The geometry placements are oMg = oMi[joint] * jMg, as pinocchio::updateGeometryPlacements computes them.
//
// Plain CPython API (no binding library): the arguments are buffers (NumPy arrays, bytes), the pair set lives in
// a capsule.
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <coal/collision_data.h>
#include <coal/distance.h>
#include <coal/shape/geometric_shapes.h>

#include <cstdint>
#include <exception>
#include <memory>
#include <string>
#include <vector>

namespace {

struct PairSet {
  std::vector<std::shared_ptr<coal::CollisionGeometry>> geoms;  // per geometry (null if in no pair)
  std::vector<coal::Matrix3s> rotation;                         // jMg, per geometry
  std::vector<coal::Vec3s> translation;
  std::vector<int64_t> joint;                                   // parent joint, per geometry
  std::vector<int64_t> first, second;                           // geometries of each pair
  std::vector<std::unique_ptr<coal::ComputeDistance>> functors;  // per pair
  // per pair, as in pinocchio::GeometryData: coal keeps the pair's last GJK guess in its request (mutable
  // cached_gjk_guess, cached_support_func_guess) and starts the pair's next call from it
  std::vector<coal::DistanceRequest> requests;
  std::vector<coal::DistanceResult> results;
  int64_t njoints = 0;
};

const char* kCapsule = "wbc.constraints.narrow_phase.PairSet";

void destroy(PyObject* capsule) {
  delete static_cast<PairSet*>(PyCapsule_GetPointer(capsule, kCapsule));
}

// A C-contiguous buffer of float64 ('d') or int64 ('q' or 'l', 8 bytes) items.
class Buffer {
 public:
  Buffer() = default;
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;
  ~Buffer() {
    if (held_) PyBuffer_Release(&view_);
  }
  bool get(PyObject* obj, bool writable, bool integer, const char* what) {
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, &view_, flags) != 0) return false;
    held_ = true;
    const char* f = view_.format ? view_.format : "B";
    if (*f == '<' || *f == '=' || *f == '@') ++f;
    bool ok = view_.itemsize == 8 && f[1] == '\0' && (integer ? (*f == 'q' || *f == 'l') : *f == 'd');
    if (!ok) {
      PyErr_Format(PyExc_TypeError, "%s: a C-contiguous %s array expected, got format '%s' (%zd bytes per item)",
                   what, integer ? "int64" : "float64", view_.format ? view_.format : "B", view_.itemsize);
      return false;
    }
    return true;
  }
  Py_ssize_t count() const { return view_.len / view_.itemsize; }
  template <typename T>
  T* data() const {
    return static_cast<T*>(view_.buf);
  }

 private:
  Py_buffer view_{};
  bool held_ = false;
};

bool count_is(const Buffer& b, Py_ssize_t n, const char* what) {
  if (b.count() != n) {
    PyErr_Format(PyExc_ValueError, "%s: %zd values expected, got %zd", what, n, b.count());
    return false;
  }
  return true;
}

std::shared_ptr<coal::CollisionGeometry> make_shape(PyObject* spec, Py_ssize_t g) {
  // ("hull", vertices (n*3 float64)) | ("box", x, y, z) | ("sphere", r) | ("cylinder", r, lz) | ("capsule", r, lz)
  if (!PyTuple_Check(spec) || PyTuple_GET_SIZE(spec) < 2 || !PyUnicode_Check(PyTuple_GET_ITEM(spec, 0))) {
    PyErr_Format(PyExc_TypeError, "shape %zd: a tuple (kind, parameters...) expected", g);
    return nullptr;
  }
  std::string kind = PyUnicode_AsUTF8(PyTuple_GET_ITEM(spec, 0));
  Py_ssize_t n = PyTuple_GET_SIZE(spec) - 1;
  std::vector<double> p;
  if (kind != "hull") {
    for (Py_ssize_t i = 1; i <= n; ++i) {
      p.push_back(PyFloat_AsDouble(PyTuple_GET_ITEM(spec, i)));
      if (PyErr_Occurred()) return nullptr;
    }
  }
  if (kind == "hull" && n == 1) {
    Buffer v;
    if (!v.get(PyTuple_GET_ITEM(spec, 1), false, false, "hull vertices")) return nullptr;
    Py_ssize_t nv = v.count() / 3;
    if (nv < 4 || v.count() != 3 * nv) {
      PyErr_Format(PyExc_ValueError, "shape %zd: hull of %zd values (3 per vertex, >= 4 vertices)", g, v.count());
      return nullptr;
    }
    auto points = std::make_shared<std::vector<coal::Vec3s>>(nv);
    const double* x = v.data<double>();
    for (Py_ssize_t i = 0; i < nv; ++i) (*points)[i] = coal::Vec3s(x[3 * i], x[3 * i + 1], x[3 * i + 2]);
    std::shared_ptr<coal::ConvexBase> hull(
        coal::ConvexBase::convexHull(points, static_cast<unsigned int>(nv), true, "Qt"));
    hull->computeLocalAABB();
    return hull;
  }
  if (kind == "box" && n == 3) return std::make_shared<coal::Box>(p[0], p[1], p[2]);
  if (kind == "sphere" && n == 1) return std::make_shared<coal::Sphere>(p[0]);
  if (kind == "cylinder" && n == 2) return std::make_shared<coal::Cylinder>(p[0], p[1]);
  if (kind == "capsule" && n == 2) return std::make_shared<coal::Capsule>(p[0], p[1]);
  PyErr_Format(PyExc_ValueError, "shape %zd: unknown kind %s with %zd parameters", g, kind.c_str(), n);
  return nullptr;
}

// new(shapes, placements, joint, pairs, njoints, gjk_tolerance) -> capsule
PyObject* create(PyObject*, PyObject* args) {
  PyObject *shapes, *placements_obj, *joint_obj, *pairs_obj;
  Py_ssize_t njoints;
  double tolerance;
  if (!PyArg_ParseTuple(args, "OOOOnd", &shapes, &placements_obj, &joint_obj, &pairs_obj, &njoints, &tolerance))
    return nullptr;
  if (!PyList_Check(shapes)) {
    PyErr_SetString(PyExc_TypeError, "shapes: a list expected");
    return nullptr;
  }
  Py_ssize_t ng = PyList_GET_SIZE(shapes);
  Buffer placements, joint, pairs;
  if (!placements.get(placements_obj, false, false, "placements") ||
      !count_is(placements, 16 * ng, "placements (ngeoms 4x4 row-major)") ||
      !joint.get(joint_obj, false, true, "joint") || !count_is(joint, ng, "joint (ngeoms)") ||
      !pairs.get(pairs_obj, false, true, "pairs"))
    return nullptr;
  auto set = std::make_unique<PairSet>();
  set->njoints = njoints;
  const double* h = placements.data<double>();
  try {
    for (Py_ssize_t g = 0; g < ng; ++g) {
      PyObject* spec = PyList_GET_ITEM(shapes, g);
      if (spec == Py_None) {
        set->geoms.emplace_back();
      } else {
        auto shape = make_shape(spec, g);
        if (!shape) return nullptr;
        set->geoms.push_back(shape);
      }
      coal::Matrix3s R;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) R(i, j) = h[16 * g + 4 * i + j];
      set->rotation.push_back(R);
      set->translation.emplace_back(h[16 * g + 3], h[16 * g + 7], h[16 * g + 11]);
      int64_t jt = joint.data<int64_t>()[g];
      if (jt < 0 || jt >= njoints) {
        PyErr_Format(PyExc_ValueError, "joint of geometry %zd: %lld not in [0, %zd)", g, (long long)jt, njoints);
        return nullptr;
      }
      set->joint.push_back(jt);
    }
    if (pairs.count() % 2) {
      PyErr_Format(PyExc_ValueError, "pairs: (npairs, 2) expected, got %zd values", pairs.count());
      return nullptr;
    }
    Py_ssize_t np = pairs.count() / 2;
    const int64_t* pr = pairs.data<int64_t>();
    for (Py_ssize_t k = 0; k < np; ++k) {
      int64_t a = pr[2 * k], b = pr[2 * k + 1];
      if (a < 0 || a >= ng || b < 0 || b >= ng || !set->geoms[a] || !set->geoms[b]) {
        PyErr_Format(PyExc_ValueError, "pair %zd: geometries (%lld, %lld) not both given", k, (long long)a,
                     (long long)b);
        return nullptr;
      }
      set->first.push_back(a);
      set->second.push_back(b);
      set->functors.emplace_back(new coal::ComputeDistance(set->geoms[a].get(), set->geoms[b].get()));
      set->requests.emplace_back(true);
      set->requests.back().gjk_tolerance = tolerance;
      set->requests.back().enable_cached_gjk_guess = true;  // deprecated in coal 3; what pinocchio sets
      set->results.emplace_back();
    }
  } catch (const std::exception& e) {
    PyErr_Format(PyExc_RuntimeError, "coal: %s", e.what());
    return nullptr;
  }
  PyObject* capsule = PyCapsule_New(set.get(), kCapsule, destroy);
  if (capsule) set.release();
  return capsule;
}

// distances(capsule, placements (njoints*12 float64: per joint, oMi's rotation column-major then its translation,
//           the memory layout of pinocchio::SE3), cand (n int64), out (>= 7n float64))
// out[0:n] distances (m), out[n:4n] witness points p1 (n, 3) WORLD (m), out[4n:7n] unit normals (n, 3) WORLD.
PyObject* distances(PyObject*, PyObject* args) {
  PyObject *capsule, *placements_obj, *cand_obj, *out_obj;
  if (!PyArg_ParseTuple(args, "OOOO", &capsule, &placements_obj, &cand_obj, &out_obj)) return nullptr;
  auto* set = static_cast<PairSet*>(PyCapsule_GetPointer(capsule, kCapsule));
  if (!set) return nullptr;
  Buffer placements, cand, out;
  if (!placements.get(placements_obj, false, false, "placements") ||
      !count_is(placements, 12 * set->njoints, "placements (njoints x 12)") ||
      !cand.get(cand_obj, false, true, "cand") || !out.get(out_obj, true, false, "out"))
    return nullptr;
  Py_ssize_t n = cand.count();
  if (out.count() < 7 * n) {
    PyErr_Format(PyExc_ValueError, "out: %zd values needed, got %zd", 7 * n, out.count());
    return nullptr;
  }
  const double* P = placements.data<double>();
  const int64_t* c = cand.data<int64_t>();
  double* o = out.data<double>();
  Py_ssize_t np = static_cast<Py_ssize_t>(set->functors.size());
  for (Py_ssize_t i = 0; i < n; ++i) {
    int64_t k = c[i];
    if (k < 0 || k >= np) {
      PyErr_Format(PyExc_IndexError, "cand[%zd] = %lld: pair index not in [0, %zd)", i, (long long)k, np);
      return nullptr;
    }
    coal::Transform3s tf[2];
    int64_t g[2] = {set->first[k], set->second[k]};
    for (int s = 0; s < 2; ++s) {
      const double* M = P + 12 * set->joint[g[s]];
      const Eigen::Map<const coal::Matrix3s> R(M);  // column-major, as Eigen (and pinocchio::SE3) stores it
      const Eigen::Map<const coal::Vec3s> p(M + 9);
      tf[s].setRotation(R * set->rotation[g[s]]);
      tf[s].setTranslation(R * set->translation[g[s]] + p);
    }
    coal::DistanceResult& result = set->results[k];
    result.clear();
    try {
      (*set->functors[k])(tf[0], tf[1], set->requests[k], result);
    } catch (const std::exception& e) {
      PyErr_Format(PyExc_RuntimeError, "coal distance of pair %lld (geometries %lld, %lld): %s", (long long)k,
                   (long long)g[0], (long long)g[1], e.what());
      return nullptr;
    }
    o[i] = result.min_distance;
    for (int j = 0; j < 3; ++j) {
      o[n + 3 * i + j] = result.nearest_points[0][j];
      o[4 * n + 3 * i + j] = result.normal[j];
    }
  }
  Py_RETURN_NONE;
}

PyMethodDef methods[] = {
    {"new", create, METH_VARARGS,
     "new(shapes, placements, joint, pairs, njoints, gjk_tolerance) -> pair set (see the module's source)"},
    {"distances", distances, METH_VARARGS,
     "distances(pair_set, placements, cand, out): coal distance, witness point p1 and normal of pairs cand"},
    {nullptr, nullptr, 0, nullptr}};

PyModuleDef module = {PyModuleDef_HEAD_INIT, "narrow_phase",
                      "coal distances of geometry pairs in one call (wbc.constraints.self_collision)", -1, methods};

}  // namespace

PyMODINIT_FUNC PyInit_narrow_phase() {
  PyObject* m = PyModule_Create(&module);
  // the coal version of the headers it was built with: used only if the coal loaded at run time is the same
  if (m && PyModule_AddStringConstant(m, "coal_version", COAL_VERSION) != 0) {
    Py_DECREF(m);
    return nullptr;
  }
  return m;
}
