// Python bindings (pybind11): `import nucleon`. A World loaded from a scene file or a dict,
// stepped, read through NumPy views of the particle pool (no copies), written from NumPy arrays
// (read in place), measured, checkpointed, and given constraint families written in Python.
// python/README.md shows the API; tests/python is its test.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "nucleon/checkpoint.h"
#include "nucleon/scene.h"
#include "nucleon/shapes.h"
#include "nucleon/world.h"

namespace py = pybind11;

namespace nucleon {
namespace {

static_assert(sizeof(Vec3) == 3 * sizeof(Real), "Vec3 is three packed scalars");

// A constraint family written in Python: its function, and the first error it raised in a
// step (an exception cannot cross the solver's threads; step() raises it afterwards).
struct PythonFamily {
  py::function function;
  std::size_t arity = 0, restSize = 0;
  std::string error;
};

// A world with what Python needs beside it: the scene's frame rate and the Python constraint
// families its registered families call (kept as long as the world).
struct PyWorld {
  World world;
  double fps = 60;
  std::vector<std::unique_ptr<PythonFamily>> families;

  ObjectId object(const py::object& which) const {
    if (py::isinstance<py::int_>(which)) {
      const auto index = which.cast<std::size_t>();
      if (index >= world.objectCount()) throw py::index_error("no object " + std::to_string(index));
      return world.objectAt(index);
    }
    const auto name = which.cast<std::string>();
    for (std::size_t i = 0; i < world.objectCount(); ++i)
      if (world.name(world.objectAt(i)) == name) return world.objectAt(i);
    throw py::key_error("no object named '" + name + "'");
  }
};

// A read-only (N, 3) view of particle vectors that keeps the world alive.
py::array_t<Real> view(std::span<const Vec3> values, const py::object& owner) {
  py::array_t<Real> array({static_cast<py::ssize_t>(values.size()), py::ssize_t{3}},
                          {static_cast<py::ssize_t>(sizeof(Vec3)), py::ssize_t{sizeof(Real)}},
                          values.empty() ? nullptr : values.data()->data(), owner);
  py::detail::array_proxy(array.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return array;
}

// An (N, 3) C-contiguous array of the world's scalar type, read in place as N Vec3.
std::span<const Vec3> points(const py::array_t<Real, py::array::c_style>& array) {
  if (array.ndim() != 2 || array.shape(1) != 3)
    throw py::value_error("expected an array of shape (N, 3)");
  return {reinterpret_cast<const Vec3*>(array.data()), static_cast<std::size_t>(array.shape(0))};
}

Scene sceneFrom(const std::string& text, const std::string& label, const std::string& folder,
                const std::vector<std::string>& overrides) {
  return parseScene(applySceneOverrides(text, overrides, label), label, folder);
}

std::unique_ptr<PyWorld> worldFrom(const Scene& scene) {
  auto w = std::make_unique<PyWorld>();
  w->world = buildWorld(scene);
  w->fps = scene.fps;
  return w;
}

// The family's evaluate: calls f(x, rest) -> (C, gradient) with (arity, 3) and (restSize,)
// arrays, under the GIL (the parallel backends' threads take turns).
Real evaluatePython(const Vec3* x, const Real* rest, Vec3* gradient, const void* userData) {
  auto& family = *const_cast<PythonFamily*>(static_cast<const PythonFamily*>(userData));
  py::gil_scoped_acquire gil;
  for (std::size_t k = 0; k < family.arity; ++k) gradient[k] = Vec3::Zero();
  if (!family.error.empty()) return 0;  // after an error: inert until step() reports it
  try {
    py::array_t<Real> xs({static_cast<py::ssize_t>(family.arity), py::ssize_t{3}});
    std::memcpy(xs.mutable_data(), x[0].data(), family.arity * sizeof(Vec3));
    py::array_t<Real> rests(static_cast<py::ssize_t>(family.restSize));
    if (family.restSize > 0)
      std::memcpy(rests.mutable_data(), rest, family.restSize * sizeof(Real));
    const py::tuple result = family.function(xs, rests);
    const auto grad =
        result[1].cast<py::array_t<Real, py::array::c_style | py::array::forcecast>>();
    if (grad.size() != static_cast<py::ssize_t>(3 * family.arity))
      throw std::runtime_error("the gradient must have shape (arity, 3)");
    std::memcpy(gradient[0].data(), grad.data(), family.arity * sizeof(Vec3));
    return result[0].cast<Real>();
  } catch (const std::exception& e) {
    family.error = e.what();
    for (std::size_t k = 0; k < family.arity; ++k) gradient[k] = Vec3::Zero();
    return 0;
  }
}

}  // namespace
}  // namespace nucleon

PYBIND11_MODULE(nucleon, m) {
  using namespace nucleon;
  m.doc() = "nucleon: a unified dynamics solver (cloth, ropes, solids, liquids) after Nucleus";
  m.attr("real") = py::dtype::of<Real>();

  py::class_<PyWorld>(m, "World")
      .def_static(
          "from_scene",
          [](const std::string& path, const std::vector<std::string>& overrides) {
            return worldFrom(sceneFrom(readSceneFile(path), path,
                                       std::filesystem::path(path).parent_path().string(),
                                       overrides));
          },
          py::arg("path"), py::arg("set") = std::vector<std::string>{},
          "A world built from a scene file; `set` changes settings as `nucleon run --set`.")
      .def_static(
          "from_dict",
          [](const py::dict& scene, const std::string& folder) {
            const std::string text =
                py::module_::import("json").attr("dumps")(scene).cast<std::string>();
            return worldFrom(sceneFrom(text, "scene dict", folder, {}));
          },
          py::arg("scene"), py::arg("folder") = ".",
          "A world built from a scene given as a dict (the scene file's JSON); meshes are looked "
          "up in `folder`.")
      .def_property_readonly("fps", [](const PyWorld& w) { return w.fps; })
      .def(
          "step",
          [](PyWorld& w, std::optional<double> dt, int count) {
            {
              py::gil_scoped_release release;  // a Python constraint takes it back when called
              for (int i = 0; i < count; ++i) w.world.step(dt ? *dt : 1.0 / w.fps);
            }
            for (const auto& family : w.families)
              if (!family->error.empty())
                throw std::runtime_error("constraint function raised: " + family->error);
          },
          py::arg("dt") = py::none(), py::arg("count") = 1,
          "Advances `count` steps of dt seconds (default: one frame of the scene).")
      .def_property_readonly("steps", [](const PyWorld& w) { return w.world.steps(); })
      .def_property_readonly("time", [](const PyWorld& w) { return w.world.time(); })
      .def_property_readonly("particle_count",
                             [](const PyWorld& w) { return w.world.particleCount(); })
      .def_property_readonly("object_names",
                             [](const PyWorld& w) {
                               std::vector<std::string> names;
                               for (std::size_t i = 0; i < w.world.objectCount(); ++i)
                                 names.push_back(w.world.name(w.world.objectAt(i)));
                               return names;
                             })
      .def(
          "positions",
          [](py::object self, py::object which) {
            const PyWorld& w = self.cast<const PyWorld&>();
            return which.is_none() ? view(w.world.positions(), self)
                                   : view(w.world.positions(w.object(which)), self);
          },
          py::arg("object") = py::none(),
          "Positions as a read-only (N, 3) NumPy view of the pool (no copy; it changes as the "
          "world steps): all particles, or one object's (by index or name).")
      .def(
          "velocities",
          [](py::object self, py::object which) {
            const PyWorld& w = self.cast<const PyWorld&>();
            if (which.is_none()) return view(w.world.velocities(), self);
            const ObjectId id = w.object(which);
            const std::size_t first = w.world.positions(id).data() - w.world.positions().data();
            return view(w.world.velocities().subspan(first, w.world.positions(id).size()), self);
          },
          py::arg("object") = py::none(), "Velocities, as positions().")
      .def(
          "inverse_masses",
          [](py::object self) {
            const PyWorld& w = self.cast<const PyWorld&>();
            const std::span<const Real> values = w.world.inverseMasses();
            py::array_t<Real> array({static_cast<py::ssize_t>(values.size())},
                                    {static_cast<py::ssize_t>(sizeof(Real))}, values.data(), self);
            py::detail::array_proxy(array.ptr())->flags &=
                ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
            return array;
          },
          "Inverse masses of all particles (0: pinned or kinematic), a read-only view.")
      .def(
          "set_positions",
          [](PyWorld& w, py::object which, const py::array_t<Real, py::array::c_style>& x) {
            w.world.setPositions(w.object(which), points(x));
          },
          "Teleports an object's particles (World::setPositions; the array is read in place).")
      .def(
          "set_velocities",
          [](PyWorld& w, py::object which, const py::array_t<Real, py::array::c_style>& v) {
            w.world.setVelocities(w.object(which), points(v));
          },
          "Sets an object's velocities (World::setVelocities).")
      .def(
          "apply_impulse",
          [](PyWorld& w, py::object which, std::array<Real, 3> j, std::optional<Index> vertex) {
            const Vec3 impulse(j[0], j[1], j[2]);
            vertex ? w.world.applyImpulse(w.object(which), *vertex, impulse)
                   : w.world.applyImpulse(w.object(which), impulse);
          },
          py::arg("object"), py::arg("impulse"), py::arg("vertex") = py::none())
      .def(
          "begin_drag",
          [](PyWorld& w, py::object which, Index vertex, std::array<Real, 3> p, Real compliance) {
            return w.world.beginDrag(w.object(which), vertex, Vec3(p[0], p[1], p[2]), compliance);
          },
          py::arg("object"), py::arg("vertex"), py::arg("point"), py::arg("compliance") = 1e-4)
      .def("move_drag",
           [](PyWorld& w, std::size_t drag, std::array<Real, 3> p) {
             w.world.moveDrag(drag, Vec3(p[0], p[1], p[2]));
           })
      .def("end_drag", [](PyWorld& w, std::size_t drag) { w.world.endDrag(drag); })
      .def(
          "remove_object",
          [](PyWorld& w, py::object which) { return w.world.removeObject(w.object(which)); },
          py::arg("object"),
          "Takes an object out for good (World::removeObject; by index or name) and returns how "
          "many attachments went with it. The particles after it move down: views from "
          "positions() and velocities() taken before are stale, take them again.")
      .def(
          "measure",
          [](const PyWorld& w) {
            const Measures m = w.world.measure();
            py::dict d;
            d["max_strain"] = m.maxStrain, d["mean_strain"] = m.meanStrain;
            d["strain_p99"] = m.strainP99, d["max_stretch"] = m.maxStretch;
            d["kinetic_energy"] = m.kineticEnergy, d["potential_energy"] = m.potentialEnergy;
            d["nan_count"] = m.nanCount, d["min_height"] = m.minHeight;
            d["intersections"] = m.intersections, d["contacts"] = m.contacts;
            d["recoveries"] = w.world.recoveries().total();
            d["primitive_contacts"] = w.world.collisionReport().contacts;
            return d;
          },
          "The measures `nucleon run` reports (strain, energy, intersections, repairs).")
      .def(
          "profile",
          [](const PyWorld& w) {
            const StepProfile& p = w.world.profile();
            py::dict d;
            d["steps"] = p.steps, d["solve"] = p.solve, d["cascade"] = p.cascade;
            d["broad_phase"] = p.broadPhase, d["narrow_phase"] = p.narrowPhase;
            d["collisions"] = p.collisions, d["predict"] = p.predict, d["update"] = p.update;
            return d;
          },
          "Seconds spent per stage since the world was made (StepProfile).")
      .def(
          "contact_points",
          [](const PyWorld& w) {
            std::vector<Vec3> points;
            w.world.contactPoints(points);
            py::array_t<Real> array({static_cast<py::ssize_t>(points.size()), py::ssize_t{3}});
            if (!points.empty())
              std::memcpy(array.mutable_data(), points.data()->data(),
                          points.size() * sizeof(Vec3));
            return array;
          },
          "Where the last substep's contacts pressed, an (M, 3) array (a copy).")
      .def("state_hash", [](const PyWorld& w) { return w.world.stateHash(); })
      .def(
          "save_checkpoint",
          [](const PyWorld& w, const std::string& path, const std::string& label) {
            std::ofstream out(path, std::ios::binary);
            saveCheckpoint(w.world, out, label);
          },
          py::arg("path"), py::arg("label") = "python")
      .def(
          "load_checkpoint",
          [](PyWorld& w, const std::string& path, const std::string& label) {
            std::ifstream in(path, std::ios::binary);
            if (!in) throw std::runtime_error(path + ": cannot open");
            loadCheckpoint(w.world, in, label);
          },
          py::arg("path"), py::arg("label") = "python")
      .def(
          "register_constraint",
          [](PyWorld& w, const std::string& name, std::size_t arity, std::size_t restSize,
             py::function evaluate, bool unilateral) {
            auto family = std::make_unique<PythonFamily>();
            family->function = std::move(evaluate);
            family->arity = arity, family->restSize = restSize;
            UserConstraintFamilyDef def;
            def.name = name, def.arity = arity, def.restSize = restSize;
            def.evaluate = &evaluatePython, def.userData = family.get();
            def.unilateral = unilateral;
            const ConstraintFamily id = w.world.registerConstraintFamily(def);
            w.families.push_back(std::move(family));
            return static_cast<std::size_t>(id);
          },
          py::arg("name"), py::arg("arity"), py::arg("rest_size"), py::arg("evaluate"),
          py::arg("unilateral") = false,
          "A constraint family written in Python: evaluate(x, rest) -> (C, gradient) with x of "
          "shape (arity, 3) and gradient of the same shape (the user API of user_constraint.h; "
          "slow: one Python call per projection).")
      .def(
          "add_constraint",
          [](PyWorld& w, py::object which, std::size_t family, std::vector<Index> particles,
             std::vector<Real> rest) {
            w.world.addConstraint(w.object(which), static_cast<ConstraintFamily>(family), particles,
                                  rest);
          },
          py::arg("object"), py::arg("family"), py::arg("particles"), py::arg("rest"));
}
