// osd_refine_bench: reference timings of OpenSubdiv's (Far, CPU, single-threaded) uniform
// Catmull-Clark refinement, to compare with limitray's own refiner in BENCHMARKS.md.
//
// Build: scripts/setup-osd.sh  (installs libosd-dev, writes target/osd/osd_refine_bench)
//
// Usage:
//   osd_refine_bench MESH.obj LEVEL [--chaikin] [--loop] [--reps N] [--dump OUT.obj] [--faces-first]
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

constexpr char const *kProgram = "osd_refine_bench";

}  // namespace

#include "osd_mesh.h"

namespace {

using Point3 = osdmesh::Point3T<float>;
using Mesh = osdmesh::MeshT<float>;
using osdmesh::createRefiner;
using osdmesh::fail;
using osdmesh::gFarError;
using osdmesh::gQuietWarnings;
using osdmesh::onFarError;
using osdmesh::onFarWarning;
using osdmesh::parseInt;
using osdmesh::readObj;

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
                 "usage: osd_refine_bench MESH.obj LEVEL [--chaikin] [--loop] [--reps N] [--dump OUT.obj] [--faces-first]\n"
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
    bool chaikin = false, facesFirst = false, loop = false;
    int reps = 5;
    long gridN = -1;
    std::string dumpPath;
    for (int a = 1; a < argc; ++a) {
        std::string arg = argv[a];
        if (arg == "--chaikin") {
            chaikin = true;
        } else if (arg == "--loop") {
            loop = true;
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

    Mesh mesh = gridN > 0 ? makeGrid(int(gridN)) : readObj<float>(positional[0]);
    if (chaikin) mesh.creaseMethod = Sdc::Options::CREASE_CHAIKIN;
    if (loop) mesh.scheme = Sdc::SCHEME_LOOP;

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
