// Vertex normals for meshes without them (scene/mesh_normals.h), and the
// Mitsuba reader's use of them:
//  * two faces meeting at 90° along an edge: each shared vertex's normal is
//    the angle-weighted mean of the two face normals (angles 63.4° and
//    26.6° at one end, where equal areas would weigh them equally); the
//    unshared vertices keep their face's normal;
//  * max_smooth_angle 40: the edge is a crease: its two vertices are copied
//    (with their uvs), each face keeps its own normal; 100: smooth again;
//  * a degenerate face adds nothing;
//  * a Mitsuba obj without normals gets them, face_normals keeps it flat,
//    max_smooth_angle creases it (each vertex then has its face's normal:
//    the mesh is shaded flat, which is the same), and a bad angle is refused.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "luz/io/error.h"
#include "luz/io/load.h"
#include "luz/scene/mesh_normals.h"
#include "temp_dir.h"

using luz::Vec2;
using luz::Vec3;

namespace {

// Face A in the plane z = 0 (normal +z), face B in the plane y = 0 (normal
// +y), sharing the edge from v0 = origin to v1 = (1, 0, 0), and a
// degenerate face on v0 and v1.
struct Roof {
  std::vector<Vec3> p{{0, 0, 0}, {1, 0, 0}, {0.5f, 1, 0}, {2, 0, 1}};
  std::vector<uint32_t> idx{0, 1, 2, 1, 0, 3, 0, 1, 0};
  std::vector<Vec2> uv{{0, 0}, {1, 0}, {0.5f, 1}, {1, 1}};
  std::vector<Vec3> n;
};

void expect_vec(const Vec3& a, const Vec3& b, const char* what) {
  EXPECT_NEAR(a.x, b.x, 1e-5f) << what;
  EXPECT_NEAR(a.y, b.y, 1e-5f) << what;
  EXPECT_NEAR(a.z, b.z, 1e-5f) << what;
}

// The unit vector of a·(0,0,1) + b·(0,1,0).
Vec3 mix_zy(double a, double b) {
  const double l = std::sqrt(a * a + b * b);
  return {0.f, float(b / l), float(a / l)};
}

}  // namespace

TEST(MeshNormals, AngleWeightedAtSharedVerticesFaceNormalsElsewhere) {
  Roof r;
  luz::compute_vertex_normals(r.p, r.idx, r.uv, r.n);
  ASSERT_EQ(r.p.size(), 4u);
  ASSERT_EQ(r.n.size(), 4u);
  // At v0: A's angle between (1,0,0) and (0.5,1,0); B's between (1,0,0) and (2,0,1).
  const double a0 = std::atan2(1.0, 0.5), b0 = std::atan2(1.0, 2.0);
  expect_vec(r.n[0], mix_zy(a0, b0), "v0");
  // At v1: A's between (-1,0,0) and (-0.5,1,0); B's between (-1,0,0) and (1,0,1).
  const double a1 = std::atan2(1.0, 0.5), b1 = M_PI - std::atan2(1.0, 1.0);
  expect_vec(r.n[1], mix_zy(a1, b1), "v1");
  expect_vec(r.n[2], {0, 0, 1}, "v2");
  expect_vec(r.n[3], {0, 1, 0}, "v3");
  EXPECT_EQ(r.idx, (std::vector<uint32_t>{0, 1, 2, 1, 0, 3, 0, 1, 0}));
}

TEST(MeshNormals, MaxSmoothAngleCreasesSharperEdges) {
  Roof r;
  luz::compute_vertex_normals(r.p, r.idx, r.uv, r.n, 40.0);
  ASSERT_EQ(r.p.size(), 6u);  // v0 and v1 copied for face B
  ASSERT_EQ(r.uv.size(), 6u);
  for (int k = 0; k < 3; ++k) expect_vec(r.n[r.idx[size_t(k)]], {0, 0, 1}, "face A");
  for (int k = 3; k < 6; ++k) expect_vec(r.n[r.idx[size_t(k)]], {0, 1, 0}, "face B");
  EXPECT_NE(r.idx[3], 1u);
  EXPECT_NE(r.idx[4], 0u);
  EXPECT_EQ(r.p[r.idx[3]].x, 1.f);
  EXPECT_EQ(r.uv[r.idx[3]].x, 1.f);
  EXPECT_EQ(r.p[r.idx[4]].x, 0.f);

  Roof wide;
  luz::compute_vertex_normals(wide.p, wide.idx, wide.uv, wide.n, 100.0);
  EXPECT_EQ(wide.p.size(), 4u);
  expect_vec(wide.n[0], mix_zy(std::atan2(1.0, 0.5), std::atan2(1.0, 2.0)), "v0 below 100°");
}

class MitsubaMeshNormals : public TempDirTest {
 protected:
  luz::Scene load(const std::string& shape_params) {
    write("roof.obj", "v 0 0 0\nv 1 0 0\nv 0.5 1 0\nv 2 0 1\nf 1 2 3\nf 2 1 4\n");
    return luz::load_scene(write("s.xml", "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n"
                                          "<shape type=\"obj\"><string name=\"filename\" value=\"roof.obj\"/>" +
                                              shape_params + "</shape>\n</scene>\n"));
  }
};

TEST_F(MitsubaMeshNormals, ObjWithoutNormalsIsSmoothUnlessAsked) {
  const luz::Scene smooth = load("");
  ASSERT_EQ(smooth.normals.size(), 4u);
  expect_vec(smooth.normals[0], mix_zy(std::atan2(1.0, 0.5), std::atan2(1.0, 2.0)), "v0");
  EXPECT_TRUE(load("<boolean name=\"face_normals\" value=\"true\"/>").normals.empty());
  const luz::Scene creased = load("<float name=\"max_smooth_angle\" value=\"40\"/>");
  EXPECT_EQ(creased.positions.size(), 6u);
  EXPECT_TRUE(creased.normals.empty());  // each vertex's normal its face's: shaded flat, as exactly
  try {
    load("<float name=\"max_smooth_angle\" value=\"-1\"/>");
    ADD_FAILURE() << "a negative max_smooth_angle was accepted";
  } catch (const luz::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("s.xml:3: max_smooth_angle must be between 0 and 180 degrees"),
              std::string::npos)
        << e.what();
  }
}
