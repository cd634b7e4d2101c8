// osd_oracle: OpenSubdiv 3.5 Far as a reference for limitray's differential tests
// (tests/osd_oracle.rs, scripts/soak-osd.sh). Everything in double precision (Far 3.5's
// PrimvarRefinerReal<double>, StencilTableReal<double>, EvaluateBasis<double>).
//
// Build: scripts/setup-osd.sh  (writes target/osd/osd_oracle)
//
// Usage:
//   osd_oracle MESH.obj [--refine N] [--eval] [--endcap gregory|bspline|legacy] [--isolation L]
//              [--loop] [--fvar MODE]
//
// --loop       Loop subdivision (Sdc::SCHEME_LOOP; every face must be a triangle) instead of
//              Catmull-Clark. Samples are then "face 0 u v" in Far's triangle parameterisation.
//
// --fvar MODE  face-varying linear interpolation of the `vt` channel (Sdc FVAR_LINEAR_*): none,
//              corners-only (default), corners-plus1, corners-plus2, boundaries, all. With
//              --refine, each level is followed by
//                fvar NVAL
//                NVAL lines "u v"                  face-varying values, Far's order
//                NF lines "n j0 .. j(n-1)"         each face's value indices
//              when the mesh has a channel (every face corner with a texture index).
//
// --refine N   uniform refinement (TopologyRefiner::RefineUniform, PrimvarRefinerReal<double>)
//              to levels 1..N; for each level prints
//                level L NV NF
//                NV lines "x y z"                  vertex positions, Far's vertex order
//                NF lines "h n i0 .. i(n-1)"       hole flag (0/1), size, 0-based vertex indices
// --eval       reads samples "face k u v" from stdin (k: sub-face of an n-gon, 0 for quads) and
//              builds Far's adaptive PatchTable (RefineAdaptive to the isolation level, default
//              10, infinitely sharp patches on, single-crease patches off, end caps of the
//              given type, default Gregory basis). Prints "eval COUNT", then one line per sample:
//                "none"                                                 (hole, no patch)
//                "ok TYPE DEPTH px py pz dux duy duz dvx dvy dvz duux duuy duuz duvx duvy duvz
//                 dvvx dvvy dvvz"
//              with TYPE Far's PatchDescriptor type (REGULAR, GREGORY_BASIS, ...) and DEPTH the
//              patch's refinement level. Derivatives are with respect to the ptex (sub-)face's
//              (u, v): ptex face = PtexIndices::GetFaceId(face) + k (OpenSubdiv's convention,
//              also limitray's); on sub-faces of non-quads Far's own derivatives are rescaled
//              (see evaluate()).
//
// OBJ input: `v x y z`, `f` (a, a/b, a/b/c, a//c; 1-based or negative), and OpenSubdiv's tags
//   t crease N/M/0 v0 v1 [v0 v1 ...] s [s ...]   0-based pairs; one sharpness or one per pair
//   t corner N/M/0 v [v ...] s [s ...]
//   t hole N/0/0 f [f ...]                       0-based faces
//   t interpolateboundary 1/0/0 m                0 none, 1 edge-and-corner, 2 edge-only
//                                                 (edge-and-corner when absent)
//   t creasemethod 0/0/1 chaikin|uniform|normal
//   t smoothtriangles 0/0/1 smooth|catmark       Sdc TRI_SUB_SMOOTH or TRI_SUB_CATMARK
// Other tags are ignored with a warning on stderr. Errors: message on stderr, exit 1.

#include <opensubdiv/far/error.h>
#include <opensubdiv/far/patchMap.h>
#include <opensubdiv/far/patchTable.h>
#include <opensubdiv/far/patchTableFactory.h>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/ptexIndices.h>
#include <opensubdiv/far/stencilTable.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyLevel.h>
#include <opensubdiv/far/topologyRefiner.h>
#include <opensubdiv/far/topologyRefinerFactory.h>
#include <opensubdiv/sdc/options.h>
#include <opensubdiv/sdc/types.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

using namespace OpenSubdiv;

namespace {

constexpr char const *kProgram = "osd_oracle";

}  // namespace

#include "osd_mesh.h"

namespace {

using Point3 = osdmesh::Point3T<double>;
using Mesh = osdmesh::MeshT<double>;
using osdmesh::createRefiner;
using osdmesh::fail;
using osdmesh::gFarError;
using osdmesh::onFarError;
using osdmesh::onFarWarning;
using osdmesh::parseInt;

// A face-varying texture coordinate for Far's templated interpolation.
struct UV {
    double u, v;
    void Clear(void * = nullptr) { u = v = 0; }
    void AddWithWeight(UV const &src, double w) {
        u += w * src.u;
        v += w * src.v;
    }
};

// Positions of every level of `r` (level 0 = control points), concatenated.
std::vector<Point3> interpolateAll(Far::TopologyRefiner const &r, std::vector<Point3> const &base, size_t extra) {
    std::vector<Point3> all(size_t(r.GetNumVerticesTotal()) + extra, Point3{0, 0, 0});
    std::copy(base.begin(), base.end(), all.begin());
    Far::PrimvarRefinerReal<double> primvar(r);
    Point3 *src = all.data();
    for (int l = 1; l <= r.GetMaxLevel(); ++l) {
        Point3 *dst = src + r.GetLevel(l - 1).GetNumVertices();
        primvar.Interpolate(l, src, dst);
        src = dst;
    }
    return all;
}

void refineUniform(Mesh const &m, int levels) {
    Far::TopologyRefiner *r = createRefiner(m);
    Far::TopologyRefiner::UniformOptions uopts(levels);
    uopts.fullTopologyInLastLevel = true;
    r->RefineUniform(uopts);
    if (gFarError || r->GetMaxLevel() != levels) fail("RefineUniform failed");
    std::vector<Point3> all = interpolateAll(*r, m.positions, 0);
    // Face-varying values of every level (PrimvarRefiner::InterpolateFaceVarying).
    std::vector<std::vector<UV>> uvLevels;
    if (r->GetNumFVarChannels() > 0) {
        std::vector<UV> base(m.uvs.size() / 2);
        for (size_t i = 0; i < base.size(); ++i) base[i] = UV{m.uvs[2 * i], m.uvs[2 * i + 1]};
        uvLevels.push_back(base);
        Far::PrimvarRefinerReal<double> primvar(*r);
        for (int l = 1; l <= levels; ++l) {
            std::vector<UV> next(size_t(r->GetLevel(l).GetNumFVarValues(0)));
            UV const *src = uvLevels.back().data();
            UV *dst = next.data();
            primvar.InterpolateFaceVarying(l, src, dst, 0);
            uvLevels.push_back(next);
        }
    }
    size_t start = 0;
    for (int l = 0; l <= levels; ++l) {
        Far::TopologyLevel const &lv = r->GetLevel(l);
        if (l > 0) {
            std::printf("level %d %d %d\n", l, lv.GetNumVertices(), lv.GetNumFaces());
            for (int v = 0; v < lv.GetNumVertices(); ++v) {
                Point3 const &p = all[start + size_t(v)];
                std::printf("%.17g %.17g %.17g\n", p.x, p.y, p.z);
            }
            if (std::getenv("OSD_ORACLE_SHARPNESS")) {
                // Debugging aid: every sharp edge and vertex of the level, on stderr.
                for (int e = 0; e < lv.GetNumEdges(); ++e) {
                    Far::ConstIndexArray ev = lv.GetEdgeVertices(e);
                    if (lv.GetEdgeSharpness(e) > 0)
                        std::fprintf(stderr, "level %d edge %d %d sharpness %.9g\n", l, ev[0], ev[1],
                                     lv.GetEdgeSharpness(e));
                }
                for (int v = 0; v < lv.GetNumVertices(); ++v)
                    if (lv.GetVertexSharpness(v) > 0)
                        std::fprintf(stderr, "level %d vertex %d sharpness %.9g\n", l, v, lv.GetVertexSharpness(v));
            }
            for (int f = 0; f < lv.GetNumFaces(); ++f) {
                Far::ConstIndexArray fv = lv.GetFaceVertices(f);
                std::printf("%d %d", lv.IsFaceHole(f) ? 1 : 0, fv.size());
                for (int k = 0; k < fv.size(); ++k) std::printf(" %d", fv[k]);
                std::printf("\n");
            }
            if (r->GetNumFVarChannels() > 0) {
                // Face-varying values of the level, then each face's value indices.
                std::vector<UV> const &vals = uvLevels[size_t(l)];
                std::printf("fvar %d\n", int(vals.size()));
                for (UV const &t : vals) std::printf("%.17g %.17g\n", t.u, t.v);
                for (int f = 0; f < lv.GetNumFaces(); ++f) {
                    Far::ConstIndexArray fvv = lv.GetFaceFVarValues(f, 0);
                    std::printf("%d", fvv.size());
                    for (int k = 0; k < fvv.size(); ++k) std::printf(" %d", fvv[k]);
                    std::printf("\n");
                }
            }
        }
        start += size_t(lv.GetNumVertices());
    }
    delete r;
}

char const *typeName(Far::PatchDescriptor::Type t) {
    switch (t) {
        case Far::PatchDescriptor::REGULAR: return "REGULAR";
        case Far::PatchDescriptor::GREGORY: return "GREGORY";
        case Far::PatchDescriptor::GREGORY_BOUNDARY: return "GREGORY_BOUNDARY";
        case Far::PatchDescriptor::GREGORY_BASIS: return "GREGORY_BASIS";
        case Far::PatchDescriptor::QUADS: return "QUADS";
        case Far::PatchDescriptor::TRIANGLES: return "TRIANGLES";
        case Far::PatchDescriptor::LOOP: return "LOOP";
        case Far::PatchDescriptor::GREGORY_TRIANGLE: return "GREGORY_TRIANGLE";
        default: return "OTHER";
    }
}

void evaluate(Mesh const &m, int isolation, Far::PatchTableFactory::Options::EndCapType endcap) {
    Far::TopologyRefiner *r = createRefiner(m);
    Far::TopologyRefiner::AdaptiveOptions aopts(isolation);
    aopts.useSingleCreasePatch = false;
    aopts.useInfSharpPatch = true;
    r->RefineAdaptive(aopts);
    if (gFarError) fail("RefineAdaptive failed");

    Far::PatchTableFactory::Options popts(isolation);
    popts.SetEndCapType(endcap);
    popts.useSingleCreasePatch = false;
    popts.useInfSharpPatch = true;
    popts.SetPatchPrecision<double>();
    Far::PatchTable const *pt = Far::PatchTableFactory::Create(*r, popts);
    if (!pt || gFarError) fail("PatchTableFactory::Create failed");

    size_t nRefined = size_t(r->GetNumVerticesTotal());
    int nLocal = pt->GetNumLocalPoints();
    std::vector<Point3> all = interpolateAll(*r, m.positions, size_t(nLocal));
    if (nLocal > 0) {
        Far::StencilTableReal<double> const *local = pt->GetLocalPointStencilTable<double>();
        if (!local) fail("no double-precision local point stencils");
        local->UpdateValues(all.data(), all.data() + nRefined);
    }
    Far::PatchMap map(*pt);
    Far::PtexIndices ptex(*r);
    int nBase = r->GetLevel(0).GetNumFaces();

    std::vector<std::string> lines;
    std::string text;
    while (std::getline(std::cin, text)) {
        std::istringstream ls(text);
        long face, k;
        double u, v;
        if (!(ls >> face >> k >> u >> v)) {
            if (text.find_first_not_of(" \t\r") == std::string::npos) continue;
            fail("bad sample line '" + text + "'");
        }
        char buf[1024];
        int n = face >= 0 && face < nBase ? r->GetLevel(0).GetFaceVertices(int(face)).size() : 0;
        if (n == 0 || k < 0 || k >= (n == 4 || m.scheme == Sdc::SCHEME_LOOP ? 1 : n)) fail("bad sample face/k in '" + text + "'");
        int id = ptex.GetFaceId(int(face)) + int(k);
        Far::PatchTable::PatchHandle const *h = map.FindPatch(id, u, v);
        if (!h) {
            lines.push_back("none");
            continue;
        }
        double w[6][20];
        pt->EvaluateBasis(*h, u, v, w[0], w[1], w[2], w[3], w[4], w[5]);
        Far::ConstIndexArray cvs = pt->GetPatchVertices(*h);
        double out[6][3] = {};
        for (int c = 0; c < cvs.size(); ++c) {
            Point3 const &p = all[size_t(cvs[c])];
            for (int d = 0; d < 6; ++d) {
                out[d][0] += w[d][c] * p.x;
                out[d][1] += w[d][c] * p.y;
                out[d][2] += w[d][c] * p.z;
            }
        }
        // Far 3.5 scales the derivatives of patches under a non-quad face by 2^depth, where
        // the ptex sub-face's (u, v) needs 2^(depth-1) (PatchParam::GetParamFraction has the
        // -NonQuadRoot(), the derivative scaling does not): measured against finite differences
        // of Far's own positions, its first derivatives there are twice the sub-face's. Undo it.
        if (pt->GetPatchParam(*h).NonQuadRoot()) {
            for (int c = 0; c < 3; ++c) {
                out[1][c] *= 0.5, out[2][c] *= 0.5;
                out[3][c] *= 0.25, out[4][c] *= 0.25, out[5][c] *= 0.25;
            }
        }
        int len = std::snprintf(buf, sizeof buf, "ok %s %d",
                                typeName(pt->GetPatchDescriptor(*h).GetType()),
                                pt->GetPatchParam(*h).GetDepth());
        for (int d = 0; d < 6; ++d)
            for (int c = 0; c < 3; ++c) len += std::snprintf(buf + len, sizeof buf - size_t(len), " %.17g", out[d][c]);
        lines.push_back(buf);
    }
    std::printf("eval %zu\n", lines.size());
    for (auto const &l : lines) std::printf("%s\n", l.c_str());
    delete pt;
    delete r;
}

void usage() {
    std::fprintf(stderr,
                 "usage: osd_oracle MESH.obj [--refine N] [--eval] [--endcap gregory|bspline|legacy] "
                 "[--isolation L] [--loop] [--fvar MODE]\n");
    std::exit(2);
}

}  // namespace

int main(int argc, char **argv) {
    Far::SetErrorCallback(onFarError);
    Far::SetWarningCallback(onFarWarning);
    std::string path;
    int levels = 0, isolation = 10;
    bool eval = false, loop = false;
    auto fvar = Sdc::Options::FVAR_LINEAR_CORNERS_ONLY;
    auto endcap = Far::PatchTableFactory::Options::ENDCAP_GREGORY_BASIS;
    for (int a = 1; a < argc; ++a) {
        std::string arg = argv[a];
        try {
            if (arg == "--refine" && a + 1 < argc) {
                levels = int(parseInt(argv[++a], "--refine"));
                if (levels < 1 || levels > 8) throw std::runtime_error("--refine must be 1..8");
            } else if (arg == "--isolation" && a + 1 < argc) {
                isolation = int(parseInt(argv[++a], "--isolation"));
                if (isolation < 1 || isolation > 10) throw std::runtime_error("--isolation must be 1..10");
            } else if (arg == "--eval") {
                eval = true;
            } else if (arg == "--loop") {
                loop = true;
            } else if (arg == "--fvar" && a + 1 < argc) {
                std::string f = argv[++a];
                if (f == "none") fvar = Sdc::Options::FVAR_LINEAR_NONE;
                else if (f == "corners-only") fvar = Sdc::Options::FVAR_LINEAR_CORNERS_ONLY;
                else if (f == "corners-plus1") fvar = Sdc::Options::FVAR_LINEAR_CORNERS_PLUS1;
                else if (f == "corners-plus2") fvar = Sdc::Options::FVAR_LINEAR_CORNERS_PLUS2;
                else if (f == "boundaries") fvar = Sdc::Options::FVAR_LINEAR_BOUNDARIES;
                else if (f == "all") fvar = Sdc::Options::FVAR_LINEAR_ALL;
                else throw std::runtime_error("unknown --fvar mode '" + f + "'");
            } else if (arg == "--endcap" && a + 1 < argc) {
                std::string e = argv[++a];
                if (e == "gregory") endcap = Far::PatchTableFactory::Options::ENDCAP_GREGORY_BASIS;
                else if (e == "bspline") endcap = Far::PatchTableFactory::Options::ENDCAP_BSPLINE_BASIS;
                else if (e == "legacy") endcap = Far::PatchTableFactory::Options::ENDCAP_LEGACY_GREGORY;
                else throw std::runtime_error("unknown end cap '" + e + "'");
            } else if (!arg.empty() && arg[0] != '-' && path.empty()) {
                path = arg;
            } else {
                usage();
            }
        } catch (std::exception const &e) {
            fail(e.what());
        }
    }
    if (path.empty() || (levels == 0 && !eval)) usage();
    Mesh m = osdmesh::readObj<double>(path);
    if (loop) m.scheme = Sdc::SCHEME_LOOP;
    m.fvarMode = fvar;
    if (levels > 0) refineUniform(m, levels);
    if (eval) evaluate(m, isolation, endcap);
    return 0;
}
