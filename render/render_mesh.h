// Triangle meshes as the renderers see them: positions, interpolated
// normals, texture coordinates in material texture units (one unit = one
// copy of the material's sample square; the tiling is already applied), the
// per-vertex tangent frame and texture scale of Wang et al. 2005 Sec. 5
// ("texture scale s, ... texture coordinate frame for each vertex"), and the
// paper's shapes (cylinder, torus, torus knot) plus a box for floors.
//
// Scene units are millimetres, the unit of the MDF, so the texture scale s is
// the length on the mesh per millimetre of the material: one texture unit
// covers |dS/dt| scene mm on the mesh and sample_size_mm of the material.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <vector>

namespace mesocap::render {

struct RenderMesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;    // unit, interpolated across faces (the displacement direction)
  std::vector<Eigen::Vector2f> texcoords;  // material texture units
  std::vector<Eigen::Vector3i> triangles;  // counter-clockwise seen from outside
  // Filled by ComputeTangentFrames:
  std::vector<Eigen::Vector4f> tangents;  // xyz unit along +x of the texture, orthogonal to the normal;
                                          // w = +-1, bitangent = w * normal x tangent
  std::vector<float> texture_scale;       // s: scene mm per material mm

  int vertex_count() const { return static_cast<int>(positions.size()); }
};

// Tangent frames and texture scale from the texture-coordinate gradients of
// the faces around each vertex (area weighted). Conditioning: a face whose
// texture coordinates are (nearly) collinear has no gradient and is skipped;
// a vertex with no usable face gets an arbitrary frame and s = 0 (no
// mesostructure there). Throws Error when the arrays disagree in size.
void ComputeTangentFrames(RenderMesh* mesh, double sample_size_mm);

// The shapes. `tiles` is how many copies of the material cover the
// shape's (u, v) parameter square. Counts of segments are clamped to >= 3.
// Cylinder about +z, base at z = 0, closed by caps (caps get a planar mapping
// at the side's density; the rim vertices are split, so the displaced shell is
// not watertight at the rim: the tiles of side and cap overlap at the crease,
// where neither the MDF nor the true geometry is meaningful).
RenderMesh MakeCylinder(double radius, double height, int segments, int rings, Eigen::Vector2d tiles);
// The side alone and the two caps alone (a scene can give the caps a plain
// albedo and so keep mesostructure off the crease).
RenderMesh MakeCylinderSide(double radius, double height, int segments, int rings, Eigen::Vector2d tiles);
RenderMesh MakeCylinderCaps(double radius, double height, int segments, Eigen::Vector2d tiles);
// Torus about +z: u along the major circle, v around the tube.
RenderMesh MakeTorus(double major_radius, double minor_radius, int major_segments, int minor_segments,
                     Eigen::Vector2d tiles);
// (p, q) torus knot tube: u along the knot, v around the tube.
RenderMesh MakeTorusKnot(double radius, double tube_radius, int p, int q, int segments, int tube_segments,
                         Eigen::Vector2d tiles);
// An axis-aligned closed box [min, max] (a floor); planar texture coordinates
// of `tiles` per 100 mm.
RenderMesh MakeBox(const Eigen::Vector3d& min, const Eigen::Vector3d& max, double tiles_per_100mm);

// An OBJ mesh (formats/obj_mesh.h) with texture coordinates on every face
// corner, scaled by `scale` (to mm); texture coordinates times `tiles`.
// Corners without normals get area-weighted face normals of their position.
// Throws FormatError naming the file when a corner has no texture coordinate.
RenderMesh LoadObjRenderMesh(const std::filesystem::path& file, double scale, Eigen::Vector2d tiles);

// Applies x -> rotation * x + translation to positions, normals and tangents.
void TransformMesh(const Eigen::Matrix3f& rotation, const Eigen::Vector3f& translation, RenderMesh* mesh);

}  // namespace mesocap::render
