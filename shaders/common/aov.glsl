// Per-pixel AOVs of the primary hit (the Aov struct: src/interface/passes.rs), written by the
// ray-traced and hybrid passes alike. Include after shade.glsl (PrimaryInfo).
#ifndef RQR_AOV_GLSL
#define RQR_AOV_GLSL
#include "interface_passes.glsl"

// The AOVs of `info` after `samples` camera samples: a miss has t 0 and instance and
// primitive -1.
Aov primary_aov(PrimaryInfo info, uint samples) {
    Aov a;
    a.normal_depth = vec4(info.normal, info.hit ? info.t : 0.0);
    a.position_inst = vec4(info.position, float(info.hit ? info.instance : -1));
    a.bary_prim = vec4(info.bary, float(info.hit ? info.primitive : -1), float(samples));
    return a;
}
#endif
