// osd_refine_bench: reference timings of OpenSubdiv's (Far, CPU, single-threaded) uniform
// Catmull-Clark refinement, to compare with limitray's own refiner in BENCHMARKS.md.
//
// Build: scripts/setup-osd.sh  (installs libosd-dev, writes target/osd/osd_refine_bench)
//
// Usage:
//   osd_refine_bench MESH.obj LEVEL [--chaikin] [--reps N] [--dump OUT.obj] [--faces-first]
//   osd_refine_bench --grid N LEVEL [--reps N] [--dump OUT.obj] [--faces-first]
//
// Prints one JSON line on stdout. Every *_ms field is the median over --reps repetitions
// (default 5); each repetition builds everything anew from the base mesh:
//   refiner_create_ms       TopologyRefinerFactory<TopologyDescriptor>::Create (base level)
//   topology_refine_ms      TopologyRefiner::RefineUniform to LEVEL
//   stencil_build_ms        StencilTableFactory::Create for the last level only, stencils
//                           expressed on the base control vertices
//   table_build_ms          topology_refine + stencil_build of the same repetition
//   stencil_apply_ms        StencilTable::UpdateValues: control points -> last level points
//   primvar_interpolate_ms  PrimvarRefiner::Interpolate level 1..LEVEL (needs no stencils,
//                           only the refined topology)
//   vertices_per_s          refined_vertices / stencil_apply time
//   primvar_vertices_per_s  refined_vertices / primvar_interpolate time
//   max_abs_diff            largest coordinate difference between the two apply paths
//
// --grid N replaces the OBJ file by an N x N grid of unit quads:
//   vertex (i, j), 0 <= i, j <= N, has index i*(N+1)+j and position
//     (x, y, z) = (i, j, 0.1*sin(0.3*i)*cos(0.2*j))     (computed in double, stored as float)
//   face (i, j), 0 <= i, j < N, has index i*N+j and vertices, counter-clockwise seen from +z,
//     (i,j), (i+1,j), (i+1,j+1), (i,j+1)
//   no tags (so boundary interpolation is edge-and-corner). N=317 gives 100,489 faces.
//
// --dump OUT.obj writes the last level (positions from PrimvarRefiner) as OBJ with 1-based
// quads; hole faces are left out. Vertex order is OpenSubdiv's: children of vertices, then of
// faces, then of edges (with --faces-first: faces, edges, vertices).
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
// Other tags (vertexedit, facevaryinginterpolateboundary, ...) are ignored with a warning.

#include <opensubdiv/far/error.h>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/stencilTable.h>
#include <opensubdiv/far/stencilTableFactory.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyLevel.h>
#include <opensubdiv/far/topologyRefiner.h>
#include <opensubdiv/far/topologyRefinerFactory.h>
#include <opensubdiv/sdc/options.h>
#include <opensubdiv/sdc/types.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

using namespace OpenSubdiv;

namespace {

// ---------------------------------------------------------------------------------------------
// Primvar type for Far's templated interpolation (Clear + AddWithWeight).

struct Point3 {
    float x, y, z;
    void Clear(void * = nullptr) { x = y = z = 0.0f; }
    void AddWithWeight(Point3 const &src, float w) {
        x += w * src.x;
        y += w * src.y;
        z += w * src.z;
    }
};

// ---------------------------------------------------------------------------------------------
// Base mesh.

struct Mesh {
    std::string name;
    std::vector<Point3> positions;
    std::vector<int> faceSizes;
    std::vector<int> faceVerts;
    std::vector<int> creasePairs;   // 2 per crease
    std::vector<float> creaseSharpness;
    std::vector<int> cornerVerts;
    std::vector<float> cornerSharpness;
    std::vector<int> holes;
    Sdc::Options::VtxBoundaryInterpolation boundary = Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER;
    Sdc::Options::CreasingMethod creaseMethod = Sdc::Options::CREASE_UNIFORM;
    Sdc::Options::TriangleSubdivision triangles = Sdc::Options::TRI_SUB_CATMARK;
};

[[noreturn]] void fail(std::string const &msg) {
    std::fprintf(stderr, "osd_refine_bench: %s\n", msg.c_str());
    std::exit(1);
}

std::string lineError(std::string const &path, int line, std::string const &msg) {
    return path + ":" + std::to_string(line) + ": " + msg;
}

long parseInt(std::string const &s, std::string const &what) {
    char *end = nullptr;
    errno = 0;
    long v = std::strtol(s.c_str(), &end, 10);
    if (s.empty() || *end != '\0' || errno != 0) throw std::runtime_error("bad " + what + " '" + s + "'");
    return v;
}

float parseFloat(std::string const &s, std::string const &what) {
    char *end = nullptr;
    errno = 0;
    float v = std::strtof(s.c_str(), &end);
    if (s.empty() || *end != '\0' || errno == ERANGE) throw std::runtime_error("bad " + what + " '" + s + "'");
    return v;
}

// One face corner "a", "a/b", "a/b/c" or "a//c": returns the 0-based vertex index.
int parseFaceCorner(std::string const &tok, int numVerts) {
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

void parseTag(Mesh &mesh, std::vector<std::string> const &tok, std::string const &path, int line) {
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
    for (long k = 0; k < nfloat; ++k) floats.push_back(parseFloat(tok[3 + nint + k], "tag float"));
    for (long k = 0; k < nstring; ++k) strings.push_back(tok[3 + nint + nfloat + k]);

    if (name == "crease") {
        if (nint < 2 || nint % 2 != 0) throw std::runtime_error("crease needs vertex pairs");
        long npairs = nint / 2;
        if (nfloat != 1 && nfloat != npairs) {
            throw std::runtime_error("crease needs one sharpness or one per pair");
        }
        for (long p = 0; p < npairs; ++p) {
            mesh.creasePairs.push_back(int(ints[2 * p]));
            mesh.creasePairs.push_back(int(ints[2 * p + 1]));
            mesh.creaseSharpness.push_back(nfloat == 1 ? floats[0] : floats[p]);
        }
    } else if (name == "corner") {
        if (nint < 1) throw std::runtime_error("corner needs vertices");
        if (nfloat != 1 && nfloat != nint) {
            throw std::runtime_error("corner needs one sharpness or one per vertex");
        }
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
        std::fprintf(stderr, "osd_refine_bench: %s\n",
                     lineError(path, line, "ignoring tag '" + name + "'").c_str());
    }
}

std::string baseName(std::string const &path) {
    size_t slash = path.find_last_of('/');
    return slash == std::string::npos ? path : path.substr(slash + 1);
}

Mesh readObj(std::string const &path) {
    std::ifstream in(path);
    if (!in) fail("cannot open " + path);
    Mesh mesh;
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
                mesh.positions.push_back({parseFloat(tok[1], "coordinate"), parseFloat(tok[2], "coordinate"),
                                          parseFloat(tok[3], "coordinate")});
            } else if (tok[0] == "f") {
                if (tok.size() < 4) throw std::runtime_error("face needs at least 3 vertices");
                int n = int(mesh.positions.size());
                for (size_t k = 1; k < tok.size(); ++k) mesh.faceVerts.push_back(parseFaceCorner(tok[k], n));
                mesh.faceSizes.push_back(int(tok.size() - 1));
            } else if (tok[0] == "t") {
                parseTag(mesh, tok, path, lineNo);
            }
            // vt, vn, g, o, s, usemtl, mtllib, ...: ignored.
        } catch (std::exception const &e) {
            fail(lineError(path, lineNo, e.what()));
        }
    }
    if (mesh.faceSizes.empty()) fail(path + ": no faces");
    int nv = int(mesh.positions.size()), nf = int(mesh.faceSizes.size());
    for (int v : mesh.creasePairs)
        if (v < 0 || v >= nv) fail(path + ": crease vertex " + std::to_string(v) + " out of range");
    for (int v : mesh.cornerVerts)
        if (v < 0 || v >= nv) fail(path + ": corner vertex " + std::to_string(v) + " out of range");
    for (int f : mesh.holes)
        if (f < 0 || f >= nf) fail(path + ": hole face " + std::to_string(f) + " out of range");
    return mesh;
}

Mesh makeGrid(int n) {
    Mesh mesh;
    mesh.name = "grid" + std::to_string(n);
    int side = n + 1;
    mesh.positions.reserve(size_t(side) * side);
    for (int i = 0; i <= n; ++i) {
        for (int j = 0; j <= n; ++j) {
            double x = i, y = j;
            double z = 0.1 * std::sin(x * 0.3) * std::cos(y * 0.2);
            mesh.positions.push_back({float(x), float(y), float(z)});
        }
    }
    mesh.faceSizes.assign(size_t(n) * n, 4);
    mesh.faceVerts.reserve(size_t(n) * n * 4);
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
            mesh.faceVerts.push_back(i * side + j);
            mesh.faceVerts.push_back((i + 1) * side + j);
            mesh.faceVerts.push_back((i + 1) * side + j + 1);
            mesh.faceVerts.push_back(i * side + j + 1);
        }
    }
    return mesh;
}

// ---------------------------------------------------------------------------------------------
// OpenSubdiv plumbing.

bool gFarError = false;
bool gQuietWarnings = false;  // set after the first repetition: its warnings repeat verbatim

void onFarError(Far::ErrorType, const char *msg) {
    // The default handler prints to stdout, which would break the JSON line.
    std::fprintf(stderr, "osd_refine_bench: OpenSubdiv error: %s\n", msg);
    gFarError = true;
}

void onFarWarning(const char *msg) {
    if (!gQuietWarnings) std::fprintf(stderr, "osd_refine_bench: OpenSubdiv warning: %s\n", msg);
}

Far::TopologyRefiner *createRefiner(Mesh const &mesh) {
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

    // Sdc::Options() defaults to VTX_BOUNDARY_NONE: always set the boundary rule explicitly.
    Sdc::Options sdc;
    sdc.SetVtxBoundaryInterpolation(mesh.boundary);
    sdc.SetCreasingMethod(mesh.creaseMethod);
    sdc.SetTriangleSubdivision(mesh.triangles);

    using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
    Far::TopologyRefiner *refiner = Factory::Create(desc, Factory::Options(Sdc::SCHEME_CATMARK, sdc));
    if (!refiner || gFarError) fail("OpenSubdiv rejected the mesh topology");
    return refiner;
}

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string jsonString(std::string const &s) {
    std::string out = "\"";
    for (char c : s) {
        if (c == '"' || c == '\\') {
            out += '\\';
            out += c;
        } else if (static_cast<unsigned char>(c) < 0x20) {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\u%04x", c);
            out += buf;
        } else {
            out += c;
        }
    }
    return out + "\"";
}

const char *boundaryName(Sdc::Options::VtxBoundaryInterpolation b) {
    switch (b) {
        case Sdc::Options::VTX_BOUNDARY_NONE: return "none";
        case Sdc::Options::VTX_BOUNDARY_EDGE_ONLY: return "edge-only";
        default: return "edge-and-corner";
    }
}

void usage() {
    std::fprintf(stderr,
                 "usage: osd_refine_bench MESH.obj LEVEL [--chaikin] [--reps N] [--dump OUT.obj] [--faces-first]\n"
                 "       osd_refine_bench --grid N LEVEL [--reps N] [--dump OUT.obj] [--faces-first]\n");
    std::exit(2);
}

long argInt(char const *s, char const *what, long lo, long hi) {
    try {
        long v = parseInt(s, what);
        if (v < lo || v > hi) throw std::runtime_error("");
        return v;
    } catch (std::exception const &) {
        fail(std::string("bad ") + what + " '" + s + "' (expected " + std::to_string(lo) + ".." +
             std::to_string(hi) + ")");
    }
}

}  // namespace

int main(int argc, char **argv) {
    Far::SetErrorCallback(onFarError);
    Far::SetWarningCallback(onFarWarning);

    std::vector<std::string> positional;
    bool chaikin = false, facesFirst = false;
    int reps = 5;
    long gridN = -1;
    std::string dumpPath;
    for (int a = 1; a < argc; ++a) {
        std::string arg = argv[a];
        if (arg == "--chaikin") {
            chaikin = true;
        } else if (arg == "--faces-first") {
            facesFirst = true;
        } else if (arg == "--reps") {
            if (++a >= argc) usage();
            reps = int(argInt(argv[a], "--reps", 1, 1000000));
        } else if (arg == "--grid") {
            if (++a >= argc) usage();
            gridN = argInt(argv[a], "--grid", 1, 20000);
        } else if (arg == "--dump") {
            if (++a >= argc) usage();
            dumpPath = argv[a];
        } else if (arg == "-h" || arg == "--help") {
            usage();
        } else if (arg.size() > 1 && arg[0] == '-' && !std::isdigit(static_cast<unsigned char>(arg[1]))) {
            std::fprintf(stderr, "osd_refine_bench: unknown option %s\n", arg.c_str());
            usage();
        } else {
            positional.push_back(arg);
        }
    }
    if (positional.size() != (gridN > 0 ? 1u : 2u)) usage();
    // RefineUniform's UniformOptions and StencilTableFactory::Options keep the level in 4 bits
    // (silently masked with & 0xf), so 15 is the real maximum.
    int level = int(argInt(positional.back().c_str(), "LEVEL", 1, 15));

    Mesh mesh = gridN > 0 ? makeGrid(int(gridN)) : readObj(positional[0]);
    if (chaikin) mesh.creaseMethod = Sdc::Options::CREASE_CHAIKIN;

    int const nBase = int(mesh.positions.size());
    std::vector<double> tCreate, tRefine, tStencilBuild, tTableBuild, tApply, tPrimvar;
    int refinedVerts = 0, refinedFaces = 0, refinedHoleFaces = 0;
    size_t numStencils = 0, numWeights = 0;
    double maxDiff = 0.0;

    // Output buffers live across repetitions and are touched first, so the timings do not
    // include page faults of fresh allocations.
    std::vector<Point3> stencilOut, primvarAll;
    std::vector<size_t> levelOffset;  // start of each level in primvarAll (level 0 = control points)

    for (int rep = 0; rep < reps; ++rep) {
        auto t0 = Clock::now();
        Far::TopologyRefiner *refiner = createRefiner(mesh);
        tCreate.push_back(msSince(t0));

        Far::TopologyRefiner::UniformOptions uopts(level);
        uopts.orderVerticesFromFacesFirst = facesFirst;
        uopts.fullTopologyInLastLevel = false;
        t0 = Clock::now();
        refiner->RefineUniform(uopts);
        tRefine.push_back(msSince(t0));
        if (gFarError || refiner->GetMaxLevel() != level) fail("RefineUniform failed");

        Far::StencilTableFactory::Options sopts;
        sopts.interpolationMode = Far::StencilTableFactory::INTERPOLATE_VERTEX;
        sopts.generateOffsets = true;
        sopts.generateControlVerts = false;       // no identity stencils for the base vertices
        sopts.generateIntermediateLevels = false; // stencils for the last level only ...
        sopts.factorizeIntermediateLevels = true; // ... expressed on the base control vertices
        sopts.maxLevel = unsigned(level);
        t0 = Clock::now();
        Far::StencilTable const *table = Far::StencilTableFactory::Create(*refiner, sopts);
        tStencilBuild.push_back(msSince(t0));
        tTableBuild.push_back(tRefine.back() + tStencilBuild.back());
        if (!table || gFarError) fail("StencilTableFactory::Create failed");

        Far::TopologyLevel const &last = refiner->GetLevel(level);
        if (rep == 0) {
            refinedVerts = last.GetNumVertices();
            refinedFaces = last.GetNumFaces();
            for (int f = 0; f < refinedFaces; ++f) refinedHoleFaces += last.IsFaceHole(f) ? 1 : 0;
            numStencils = size_t(table->GetNumStencils());
            numWeights = table->GetWeights().size();
            if (int(numStencils) != refinedVerts) {
                fail("stencil count " + std::to_string(numStencils) + " != refined vertices " +
                     std::to_string(refinedVerts));
            }
            stencilOut.assign(size_t(refinedVerts), Point3{0, 0, 0});
            levelOffset.assign(size_t(level) + 2, 0);
            for (int l = 0; l <= level; ++l)
                levelOffset[l + 1] = levelOffset[l] + size_t(refiner->GetLevel(l).GetNumVertices());
            primvarAll.assign(levelOffset[level + 1], Point3{0, 0, 0});
            std::copy(mesh.positions.begin(), mesh.positions.end(), primvarAll.begin());
        }

        t0 = Clock::now();
        table->UpdateValues(mesh.positions.data(), stencilOut.data());
        tApply.push_back(msSince(t0));

        Far::PrimvarRefiner primvar(*refiner);
        t0 = Clock::now();
        for (int l = 1; l <= level; ++l) {
            Point3 const *src = primvarAll.data() + levelOffset[l - 1];
            Point3 *dst = primvarAll.data() + levelOffset[l];
            primvar.Interpolate(l, src, dst);
        }
        tPrimvar.push_back(msSince(t0));

        if (rep == 0) {
            Point3 const *fin = primvarAll.data() + levelOffset[level];
            for (int v = 0; v < refinedVerts; ++v) {
                maxDiff = std::max({maxDiff, double(std::fabs(fin[v].x - stencilOut[v].x)),
                                    double(std::fabs(fin[v].y - stencilOut[v].y)),
                                    double(std::fabs(fin[v].z - stencilOut[v].z))});
            }
            if (!dumpPath.empty()) {
                std::FILE *out = std::fopen(dumpPath.c_str(), "w");
                if (!out) fail("cannot write " + dumpPath);
                std::fprintf(out, "# osd_refine_bench dump: %s level %d, OpenSubdiv %s vertex order\n",
                             mesh.name.c_str(), level,
                             facesFirst ? "faces-edges-vertices" : "vertices-faces-edges");
                std::fprintf(out, "# %d vertices, %d faces (%d hole faces left out)\n", refinedVerts,
                             refinedFaces - refinedHoleFaces, refinedHoleFaces);
                for (int v = 0; v < refinedVerts; ++v)
                    std::fprintf(out, "v %.9g %.9g %.9g\n", fin[v].x, fin[v].y, fin[v].z);
                for (int f = 0; f < refinedFaces; ++f) {
                    if (last.IsFaceHole(f)) continue;
                    Far::ConstIndexArray fv = last.GetFaceVertices(f);
                    std::fputc('f', out);
                    for (int k = 0; k < fv.size(); ++k) std::fprintf(out, " %d", fv[k] + 1);
                    std::fputc('\n', out);
                }
                if (std::fclose(out) != 0) fail("error writing " + dumpPath);
            }
        }

        delete table;
        delete refiner;
        gQuietWarnings = true;
    }

    double applyMs = median(tApply), primvarMs = median(tPrimvar);
    std::printf(
        "{\"mesh\":%s,\"level\":%d,\"base_vertices\":%d,\"base_faces\":%d,"
        "\"refined_vertices\":%d,\"refined_faces\":%d,\"refined_hole_faces\":%d,"
        "\"boundary\":\"%s\",\"crease_method\":\"%s\",\"reps\":%d,\"threads\":1,"
        "\"refiner_create_ms\":%.4f,\"topology_refine_ms\":%.4f,\"stencil_build_ms\":%.4f,"
        "\"table_build_ms\":%.4f,\"stencil_apply_ms\":%.4f,\"primvar_interpolate_ms\":%.4f,"
        "\"vertices_per_s\":%.0f,\"primvar_vertices_per_s\":%.0f,"
        "\"stencils\":%zu,\"stencil_weights\":%zu,\"max_abs_diff\":%.3g}\n",
        jsonString(mesh.name).c_str(), level, nBase, int(mesh.faceSizes.size()), refinedVerts,
        refinedFaces, refinedHoleFaces, boundaryName(mesh.boundary),
        mesh.creaseMethod == Sdc::Options::CREASE_CHAIKIN ? "chaikin" : "uniform", reps, median(tCreate),
        median(tRefine), median(tStencilBuild), median(tTableBuild), applyMs, primvarMs,
        applyMs > 0 ? refinedVerts / (applyMs * 1e-3) : 0.0,
        primvarMs > 0 ? refinedVerts / (primvarMs * 1e-3) : 0.0, numStencils, numWeights, maxDiff);
    return 0;
}
