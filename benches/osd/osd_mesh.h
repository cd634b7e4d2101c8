// osd_mesh.h: the OBJ reader (with OpenSubdiv's tags) and the Far refiner set-up shared by the
// reference programs osd_refine_bench.cpp (float, for timings) and osd_oracle.cpp (double, for
// the differential tests). Include after defining `kProgram` (the name used in messages).
//
// OBJ input: `v x y z`, `f` with n-gons in the a, a/b, a/b/c and a//c forms, 1-based or
// negative indices, and OpenSubdiv's tags:
//   t crease N/M/0 v0 v1 [v0 v1 ...] s [s ...]   0-based vertex pairs; one sharpness for all
//                                                 pairs or one per pair
//   t corner N/M/0 v [v ...] s [s ...]           one sharpness for all or one per vertex
//   t hole N/0/0 f [f ...]                       0-based face indices
//   t interpolateboundary 1/0/0 m                0 none, 1 edge-and-corner, 2 edge-only
//                                                 (edge-and-corner when absent)
//   t creasemethod 0/0/1 chaikin|uniform|normal
//   t smoothtriangles 0/0/1 smooth|catmark       Sdc TRI_SUB_SMOOTH or TRI_SUB_CATMARK
// Other tags (vertexedit, facevaryinginterpolateboundary, ...) are ignored with a warning;
// `vt u [v]` and the texture indices of `f a/b[/c]` form one face-varying channel when every
// face corner has one; vn, g, o, s, usemtl, mtllib, ... are ignored. Errors: `PROGRAM: FILE:LINE: message` on
// stderr, exit 1.
#pragma once

#include <opensubdiv/far/error.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefiner.h>
#include <opensubdiv/far/topologyRefinerFactory.h>
#include <opensubdiv/sdc/options.h>
#include <opensubdiv/sdc/types.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace osdmesh {

using namespace OpenSubdiv;

// Primvar type for Far's templated interpolation (Clear + AddWithWeight).
template <class Real>
struct Point3T {
    Real x, y, z;
    void Clear(void * = nullptr) { x = y = z = Real(0); }
    void AddWithWeight(Point3T const &src, Real w) {
        x += w * src.x;
        y += w * src.y;
        z += w * src.z;
    }
};

// A base mesh with its tags.
template <class Real>
struct MeshT {
    std::string name;
    std::vector<Point3T<Real>> positions;
    std::vector<int> faceSizes;
    std::vector<int> faceVerts;
    std::vector<int> creasePairs;  // 2 per crease
    std::vector<float> creaseSharpness;
    std::vector<int> cornerVerts;
    std::vector<float> cornerSharpness;
    std::vector<int> holes;
    Sdc::Options::VtxBoundaryInterpolation boundary = Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER;
    Sdc::Options::CreasingMethod creaseMethod = Sdc::Options::CREASE_UNIFORM;
    Sdc::Options::TriangleSubdivision triangles = Sdc::Options::TRI_SUB_CATMARK;
    Sdc::SchemeType scheme = Sdc::SCHEME_CATMARK;  // SCHEME_LOOP with the programs' --loop
    // Face-varying texture coordinates (`vt`, and the `b` of `f a/b`): one channel when every
    // face corner has one, refined with `fvarMode` (the oracle's --fvar).
    std::vector<Real> uvs;     // 2 per `vt`
    std::vector<int> faceUVs;  // per face corner, 0-based; empty without a channel
    bool anyCornerWithoutUV = false;
    Sdc::Options::FVarLinearInterpolation fvarMode = Sdc::Options::FVAR_LINEAR_CORNERS_ONLY;
};

[[noreturn]] inline void fail(std::string const &msg) {
    std::fprintf(stderr, "%s: %s\n", kProgram, msg.c_str());
    std::exit(1);
}

inline std::string lineError(std::string const &path, int line, std::string const &msg) {
    return path + ":" + std::to_string(line) + ": " + msg;
}

inline long parseInt(std::string const &s, std::string const &what) {
    char *end = nullptr;
    errno = 0;
    long v = std::strtol(s.c_str(), &end, 10);
    if (s.empty() || *end != '\0' || errno != 0) throw std::runtime_error("bad " + what + " '" + s + "'");
    return v;
}

template <class Real>
Real parseReal(std::string const &s, std::string const &what) {
    char *end = nullptr;
    errno = 0;
    Real v = std::is_same<Real, float>::value ? Real(std::strtof(s.c_str(), &end))
                                              : Real(std::strtod(s.c_str(), &end));
    if (s.empty() || *end != '\0' || errno == ERANGE) throw std::runtime_error("bad " + what + " '" + s + "'");
    return v;
}

// One face corner "a", "a/b", "a/b/c" or "a//c": returns the 0-based vertex index.
inline int parseFaceCorner(std::string const &tok, int numVerts) {
    std::string head = tok.substr(0, tok.find('/'));
    long idx = parseInt(head, "face vertex index");
    long v;
    if (idx > 0) {
        v = idx - 1;
    } else if (idx < 0) {
        v = numVerts + idx;
    } else {
        throw std::runtime_error("face vertex index 0 (OBJ indices start at 1)");
    }
    if (v < 0 || v >= numVerts) {
        throw std::runtime_error("face vertex index " + head + " out of range (" +
                                 std::to_string(numVerts) + " vertices so far)");
    }
    return int(v);
}

// The texture index of a face corner "a/b" or "a/b/c" (0-based), or -1 without one.
inline int parseFaceUV(std::string const &tok, int numUVs) {
    size_t first = tok.find('/');
    if (first == std::string::npos) return -1;
    size_t second = tok.find('/', first + 1);
    std::string mid = tok.substr(first + 1, second == std::string::npos ? std::string::npos : second - first - 1);
    if (mid.empty()) return -1;
    long idx = parseInt(mid, "face texture index");
    long t = idx > 0 ? idx - 1 : numUVs + idx;
    if (idx == 0 || t < 0 || t >= numUVs) {
        throw std::runtime_error("face texture index " + mid + " out of range (" + std::to_string(numUVs) +
                                 " texture coordinates so far)");
    }
    return int(t);
}

template <class Real>
void parseTag(MeshT<Real> &mesh, std::vector<std::string> const &tok, std::string const &path, int line) {
    // tok[0] == "t", tok[1] == name, tok[2] == "nint/nfloat[/nstring]"
    if (tok.size() < 3) throw std::runtime_error("tag without argument counts");
    std::string const &name = tok[1];
    std::vector<std::string> counts;
    {
        std::stringstream ss(tok[2]);
        std::string c;
        while (std::getline(ss, c, '/')) counts.push_back(c);
    }
    if (counts.size() < 2 || counts.size() > 3) throw std::runtime_error("bad tag counts '" + tok[2] + "'");
    long nint = parseInt(counts[0], "tag int count");
    long nfloat = parseInt(counts[1], "tag float count");
    long nstring = counts.size() == 3 ? parseInt(counts[2], "tag string count") : 0;
    if (nint < 0 || nfloat < 0 || nstring < 0) throw std::runtime_error("negative tag count");
    if (long(tok.size()) != 3 + nint + nfloat + nstring) {
        throw std::runtime_error("tag '" + name + "' has " + std::to_string(tok.size() - 3) +
                                 " arguments, its counts say " + std::to_string(nint + nfloat + nstring));
    }
    std::vector<long> ints;
    std::vector<float> floats;
    std::vector<std::string> strings;
    for (long k = 0; k < nint; ++k) ints.push_back(parseInt(tok[3 + k], "tag int"));
    for (long k = 0; k < nfloat; ++k) floats.push_back(parseReal<float>(tok[3 + nint + k], "tag float"));
    for (long k = 0; k < nstring; ++k) strings.push_back(tok[3 + nint + nfloat + k]);

    if (name == "crease") {
        if (nint < 2 || nint % 2 != 0) throw std::runtime_error("crease needs vertex pairs");
        long npairs = nint / 2;
        if (nfloat != 1 && nfloat != npairs) throw std::runtime_error("crease needs one sharpness or one per pair");
        for (long p = 0; p < npairs; ++p) {
            mesh.creasePairs.push_back(int(ints[2 * p]));
            mesh.creasePairs.push_back(int(ints[2 * p + 1]));
            mesh.creaseSharpness.push_back(nfloat == 1 ? floats[0] : floats[p]);
        }
    } else if (name == "corner") {
        if (nint < 1) throw std::runtime_error("corner needs vertices");
        if (nfloat != 1 && nfloat != nint) throw std::runtime_error("corner needs one sharpness or one per vertex");
        for (long k = 0; k < nint; ++k) {
            mesh.cornerVerts.push_back(int(ints[k]));
            mesh.cornerSharpness.push_back(nfloat == 1 ? floats[0] : floats[k]);
        }
    } else if (name == "hole") {
        for (long f : ints) mesh.holes.push_back(int(f));
    } else if (name == "interpolateboundary") {
        if (nint != 1) throw std::runtime_error("interpolateboundary needs one int");
        switch (ints[0]) {
            case 0: mesh.boundary = Sdc::Options::VTX_BOUNDARY_NONE; break;
            case 1: mesh.boundary = Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER; break;
            case 2: mesh.boundary = Sdc::Options::VTX_BOUNDARY_EDGE_ONLY; break;
            default: throw std::runtime_error("interpolateboundary must be 0, 1 or 2");
        }
    } else if (name == "creasemethod") {
        if (nstring != 1) throw std::runtime_error("creasemethod needs one string");
        if (strings[0] == "chaikin") {
            mesh.creaseMethod = Sdc::Options::CREASE_CHAIKIN;
        } else if (strings[0] == "uniform" || strings[0] == "normal") {
            mesh.creaseMethod = Sdc::Options::CREASE_UNIFORM;
        } else {
            throw std::runtime_error("unknown creasemethod '" + strings[0] + "'");
        }
    } else if (name == "smoothtriangles") {
        if (nstring != 1) throw std::runtime_error("smoothtriangles needs one string");
        if (strings[0] == "smooth") {
            mesh.triangles = Sdc::Options::TRI_SUB_SMOOTH;
        } else if (strings[0] == "catmark") {
            mesh.triangles = Sdc::Options::TRI_SUB_CATMARK;
        } else {
            throw std::runtime_error("unknown smoothtriangles '" + strings[0] + "'");
        }
    } else {
        std::fprintf(stderr, "%s: %s\n", kProgram, lineError(path, line, "ignoring tag '" + name + "'").c_str());
    }
}

inline std::string baseName(std::string const &path) {
    size_t slash = path.find_last_of('/');
    return slash == std::string::npos ? path : path.substr(slash + 1);
}

template <class Real>
MeshT<Real> readObj(std::string const &path) {
    std::ifstream in(path);
    if (!in) fail("cannot open " + path);
    MeshT<Real> mesh;
    mesh.name = baseName(path);
    std::string text;
    int lineNo = 0;
    while (std::getline(in, text)) {
        ++lineNo;
        if (!text.empty() && text.back() == '\r') text.pop_back();
        size_t hash = text.find('#');
        if (hash != std::string::npos) text.erase(hash);
        std::istringstream ls(text);
        std::vector<std::string> tok;
        for (std::string t; ls >> t;) tok.push_back(t);
        if (tok.empty()) continue;
        try {
            if (tok[0] == "v") {
                if (tok.size() < 4) throw std::runtime_error("vertex needs 3 coordinates");
                mesh.positions.push_back({parseReal<Real>(tok[1], "coordinate"), parseReal<Real>(tok[2], "coordinate"),
                                          parseReal<Real>(tok[3], "coordinate")});
            } else if (tok[0] == "vt") {
                if (tok.size() < 2) throw std::runtime_error("texture coordinate needs a value");
                mesh.uvs.push_back(parseReal<Real>(tok[1], "texture coordinate"));
                mesh.uvs.push_back(tok.size() > 2 ? parseReal<Real>(tok[2], "texture coordinate") : Real(0));
            } else if (tok[0] == "f") {
                if (tok.size() < 4) throw std::runtime_error("face needs at least 3 vertices");
                int n = int(mesh.positions.size());
                int nt = int(mesh.uvs.size() / 2);
                for (size_t k = 1; k < tok.size(); ++k) {
                    mesh.faceVerts.push_back(parseFaceCorner(tok[k], n));
                    int t = parseFaceUV(tok[k], nt);
                    if (t < 0) mesh.anyCornerWithoutUV = true;
                    mesh.faceUVs.push_back(t);
                }
                mesh.faceSizes.push_back(int(tok.size() - 1));
            } else if (tok[0] == "t") {
                parseTag(mesh, tok, path, lineNo);
            }
        } catch (std::exception const &e) {
            fail(lineError(path, lineNo, e.what()));
        }
    }
    if (mesh.faceSizes.empty()) fail(path + ": no faces");
    // Like limitray's reader: texture indices only when every face corner has one.
    if (mesh.anyCornerWithoutUV) mesh.faceUVs.clear();
    int nv = int(mesh.positions.size()), nf = int(mesh.faceSizes.size());
    for (int v : mesh.creasePairs)
        if (v < 0 || v >= nv) fail(path + ": crease vertex " + std::to_string(v) + " out of range");
    for (int v : mesh.cornerVerts)
        if (v < 0 || v >= nv) fail(path + ": corner vertex " + std::to_string(v) + " out of range");
    for (int f : mesh.holes)
        if (f < 0 || f >= nf) fail(path + ": hole face " + std::to_string(f) + " out of range");
    return mesh;
}

// Far's error and warning callbacks (its defaults print to stdout, which carries the results).
inline bool gFarError = false;
inline bool gQuietWarnings = false;

inline void onFarError(Far::ErrorType, const char *msg) {
    std::fprintf(stderr, "%s: OpenSubdiv error: %s\n", kProgram, msg);
    gFarError = true;
}

inline void onFarWarning(const char *msg) {
    if (!gQuietWarnings) std::fprintf(stderr, "%s: OpenSubdiv warning: %s\n", kProgram, msg);
}

// The refiner (Catmark, or Loop with `mesh.scheme`) of `mesh` with its tags and options; exits when Far rejects the topology.
template <class Real>
Far::TopologyRefiner *createRefiner(MeshT<Real> const &mesh) {
    Far::TopologyDescriptor desc;
    desc.numVertices = int(mesh.positions.size());
    desc.numFaces = int(mesh.faceSizes.size());
    desc.numVertsPerFace = mesh.faceSizes.data();
    desc.vertIndicesPerFace = mesh.faceVerts.data();
    desc.numCreases = int(mesh.creaseSharpness.size());
    desc.creaseVertexIndexPairs = mesh.creasePairs.data();
    desc.creaseWeights = mesh.creaseSharpness.data();
    desc.numCorners = int(mesh.cornerVerts.size());
    desc.cornerVertexIndices = mesh.cornerVerts.data();
    desc.cornerWeights = mesh.cornerSharpness.data();
    desc.numHoles = int(mesh.holes.size());
    desc.holeIndices = mesh.holes.data();
    Far::TopologyDescriptor::FVarChannel channel;
    if (!mesh.faceUVs.empty()) {
        channel.numValues = int(mesh.uvs.size() / 2);
        channel.valueIndices = mesh.faceUVs.data();
        desc.numFVarChannels = 1;
        desc.fvarChannels = &channel;
    }

    // Sdc::Options() defaults to VTX_BOUNDARY_NONE: always set the boundary rule explicitly.
    Sdc::Options sdc;
    sdc.SetVtxBoundaryInterpolation(mesh.boundary);
    sdc.SetCreasingMethod(mesh.creaseMethod);
    sdc.SetTriangleSubdivision(mesh.triangles);
    sdc.SetFVarLinearInterpolation(mesh.fvarMode);

    using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
    Far::TopologyRefiner *refiner = Factory::Create(desc, Factory::Options(mesh.scheme, sdc));
    if (!refiner || gFarError) fail("OpenSubdiv rejected the mesh topology");
    return refiner;
}

}  // namespace osdmesh
