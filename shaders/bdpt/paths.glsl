// Where a bdpt sample's two subpaths live, for subpath.glsl (which writes them through CAM(i) /
// LGT(i) indices into `vtx`) and connect.glsl (which reads vertex i of either through CAMV(i) /
// LGTV(i)):
//   - per-pixel design (default): both in one private array, camera first, then light;
//   - split design, light pass (BDPT_LIGHT_PASS): the light subpath alone in `vtx`; the camera
//     side is only the fresh lens point light tracing makes, so CAMV is a blank camera vertex;
//   - split design, camera pass (BDPT_CAMERA_PASS): the camera subpath alone in `vtx`; the light
//     vertices come from the light pass's buffer (store.glsl).
#ifndef BDPT_PATHS_GLSL
#define BDPT_PATHS_GLSL
#include "bdpt/vertex.glsl"

// Pixels sharing one light subpath per sample (split design; GpuPush::flags bits 24–27 hold its
// log2, 0 in the per-pixel design): the light pass traces one light subpath per K pixels and
// each pixel's camera subpath joins the shared one (store.glsl). Per camera sample there are
// then 1/K light subpaths: light tracing's (t = 1) contributions count for the block's pixels
// (bdpt_light_weight) and its density in the MIS weights 1/K times (strategies.glsl,
// connect.glsl; any weights that sum to 1 over the strategies keep the estimate unbiased).
uint bdpt_share_log2() { return (pc.flags >> PUSH_FLAG_BDPT_SHARE_SHIFT) & 0xfu; }
float bdpt_share() { return float(1u << bdpt_share_log2()); }
// The camera samples this thread's light subpath stands for in light tracing: the pixels of
// its block (K, fewer at a row's ends; store.glsl), so that they add up to one light subpath
// per pixel and sample. Set by the light pass's main; 1 elsewhere.
float bdpt_light_weight = 1.0;

#if defined(BDPT_LIGHT_PASS)
#define CAM(i) 0
#define LGT(i) (i)
Vertex vtx[BDPT_MAX_LIGHT];
#define CAMV(i) vertex_blank(VTX_CAMERA)
#define LGTV(i) vtx[LGT(i)]
#elif defined(BDPT_CAMERA_PASS)
#include "bdpt/store.glsl"
#define CAM(i) (i)
#define LGT(i) 0
Vertex vtx[BDPT_MAX_CAM];
#define CAMV(i) vtx[CAM(i)]
#define LGTV(i) light_vertex_load(i)
#else
#define CAM(i) (i)
#define LGT(i) (BDPT_MAX_CAM + (i))
Vertex vtx[BDPT_MAX_CAM + BDPT_MAX_LIGHT];
#define CAMV(i) vtx[CAM(i)]
#define LGTV(i) vtx[LGT(i)]
#endif

#endif
