// Surface reconstruction shared by every pass (ray-traced hits and the G-buffer raster pass):
// material evaluation with texture LOD from ray cones, normal mapping, and light incidence.
// Include after scene.glsl.
#ifndef RQR_SURFACE_GLSL
#define RQR_SURFACE_GLSL
#extension GL_EXT_control_flow_attributes : require

#define BIG_FLOAT 3.0e38

struct Surface {
    vec3 position;
    vec3 ng;          // geometric normal, facing the incoming ray
    vec3 n;           // shading normal (normal-mapped), same side as ng
    vec3 ng_front;    // geometric normal of the glTF front face (unflipped)
    bool front_face;
    vec3 base_color;
    float alpha;
    float metallic;
    float roughness;
    vec3 emissive;
    float occlusion;
    float transmission;
    float ior;
    vec3 atten_color;
    float atten_dist;
    uint alpha_mode;
    uint material;
    // KHR_materials_specular / clearcoat / sheen; read only when `layered` (see
    // surface_layers); other materials shade with the plain metallic-roughness code.
    bool layered;
    float specular;
    vec3 specular_color;
    float clearcoat;
    float clearcoat_roughness;
    vec3 clearcoat_n;  // clearcoat shading normal, same side as ng
    vec3 sheen_color;
    float sheen_roughness;
};

// The layered-material parameters of material `m` from its factors alone (no textures).
void surface_layers(inout Surface s, GpuMaterial m) {
    s.layered = (m.flags & MATERIAL_LAYERED) != 0u;
    s.specular = m.specular;
    s.specular_color = m.specular_color;
    s.clearcoat = m.clearcoat;
    s.clearcoat_roughness = m.clearcoat_roughness;
    s.clearcoat_n = s.n;
    s.sheen_color = m.sheen_color;
    s.sheen_roughness = m.sheen_roughness;
}

// Samples a texture slot at the LOD of a ray cone: `lod_world` is log2(cone width / cos) minus
// half log2 of the triangle's world area (or -BIG_FLOAT for mip 0); `uv_areas` holds twice the
// triangle's area in TEXCOORD sets 0 and 1. The slot's texel footprint uses the area of ITS set
// after ITS KHR_texture_transform (|det| of the 2x2 part scales areas): a quantized mesh whose
// integer UVs are scaled by 1/4096 in the transform would otherwise pick a mip 12 levels too
// coarse (a flat colour), and a slot on TEXCOORD_1 would use TEXCOORD_0's density.
vec4 sample_slot(GpuTextureSlot slot, vec2 uv0, vec2 uv1, float lod_world, vec2 uv_areas) {
    ivec2 size = textureSize(textures[nonuniformEXT(slot.texture)], 0);
    float det = abs(slot.row0.x * slot.row1.y - slot.row0.y * slot.row1.x);
    float uv_area = (slot.tex_coord == 1u ? uv_areas.y : uv_areas.x) * det;
    float lod = uv_area > 0.0 ? lod_world + 0.5 * log2(uv_area * float(size.x) * float(size.y)) : 0.0;
    return textureLod(textures[nonuniformEXT(slot.texture)], texture_uv(slot, uv0, uv1), max(lod, 0.0));
}

// Barycentrics (b1, b2) and distance t where the ray (origin, unit dir) meets triangle
// (instance, prim), clamped onto the triangle. The raster passes know which triangle covers a
// sample and take the hit from this intersection, like the ray backends, instead of the
// rasterizer's interpolation: refraction and reflection magnify interpolation error, and this
// keeps hybrid hits within float noise of ray-traced ones. A sample just outside the triangle's
// edges is clamped to it; t is then the clamped point's distance along dir. `fallback` is kept
// for a ray parallel to the triangle.
vec3 ray_triangle_hit(uint instance, uint prim, vec3 origin, vec3 dir, vec2 fallback) {
    GpuInstance inst = scene_instance(instance);
    GpuGeometry g = scene_geometry(inst.geometry);
    uvec3 tri = scene_triangle(g, prim);
    vec3 o = (inst.world_to_object * vec4(origin, 1.0)).xyz;
    vec3 d = mat3(inst.world_to_object) * dir;
    vec3 a = scene_position(tri.x), e1 = scene_position(tri.y) - a, e2 = scene_position(tri.z) - a;
    vec2 bary = fallback;
    vec3 pv = cross(d, e2);
    float det = dot(e1, pv);
    if (abs(det) > 1e-30) {
        vec3 tv = o - a;
        vec2 uv = vec2(dot(tv, pv), dot(d, cross(tv, e1))) / det;
        uv = max(uv, vec2(0.0));
        float sum = uv.x + uv.y;
        bary = sum > 1.0 ? uv / sum : uv;
    }
    vec3 p = (inst.object_to_world * vec4(a + bary.x * e1 + bary.y * e2, 1.0)).xyz;
    return vec3(bary, dot(p - origin, dir));
}

// Shades the material of triangle (instance, prim) at barycentrics `bary`.
// `cone_width` is the ray cone's width at the hit (texture LOD, Akenine-Moller et al. 2019);
// pass a negative width to sample mip 0. `dir` is the unit ray direction.
Surface surface_at(uint instance, uint prim, vec2 bary, vec3 dir, float cone_width) {
    GpuInstance inst = scene_instance(instance);
    GpuGeometry g = scene_geometry(inst.geometry);
    GpuMaterial m = scene_material(g.material);
    uvec3 tri = scene_triangle(g, prim);
    vec3 w = vec3(1.0 - bary.x - bary.y, bary.x, bary.y);
    vec3 p0 = scene_position(tri.x), p1 = scene_position(tri.y), p2 = scene_position(tri.z);
    // Attributes are read member by member, colours and tangents only where the geometry has
    // them (and tangents only for normal mapping): on a CPU Vulkan every component loaded costs
    // one scalar load per SIMD lane.
    VertexBuf verts = VertexBuf(scene.attributes);
    vec2 uv0_a = verts.v[tri.x].uv0, uv0_b = verts.v[tri.y].uv0, uv0_c = verts.v[tri.z].uv0;
    vec2 uv1_a = verts.v[tri.x].uv1, uv1_b = verts.v[tri.y].uv1, uv1_c = verts.v[tri.z].uv1;

    Surface s;
    s.material = g.material;
    mat3 n2w = mat3(inst.normal_to_world);
    s.position = (inst.object_to_world * vec4(w.x * p0 + w.y * p1 + w.z * p2, 1.0)).xyz;
    vec3 ng_obj = cross(p1 - p0, p2 - p0);
    s.ng_front = normalize(n2w * ng_obj);
    s.front_face = dot(s.ng_front, dir) < 0.0;
    s.ng = s.front_face ? s.ng_front : -s.ng_front;
    vec3 n = n2w * (w.x * verts.v[tri.x].normal + w.y * verts.v[tri.y].normal + w.z * verts.v[tri.z].normal);
    n = dot(n, n) > 0.0 ? normalize(n) : s.ng_front;
    vec2 uv0 = w.x * uv0_a + w.y * uv0_b + w.z * uv0_c;
    vec2 uv1 = w.x * uv1_a + w.y * uv1_b + w.z * uv1_c;
    vec4 vcolor = vec4(1.0);
    if ((g.flags & GEOMETRY_HAS_COLORS) != 0u) {
        vcolor = w.x * verts.v[tri.x].color + w.y * verts.v[tri.y].color + w.z * verts.v[tri.z].color;
    }

    float lod_world = -BIG_FLOAT;
    vec2 uv_areas = vec2(0.0);
    if (cone_width > 0.0) {
        mat3 o2w = mat3(inst.object_to_world);
        float world_area = length(cross(o2w * (p1 - p0), o2w * (p2 - p0)));
        uv_areas = abs(vec2(
            (uv0_b.x - uv0_a.x) * (uv0_c.y - uv0_a.y) - (uv0_c.x - uv0_a.x) * (uv0_b.y - uv0_a.y),
            (uv1_b.x - uv1_a.x) * (uv1_c.y - uv1_a.y) - (uv1_c.x - uv1_a.x) * (uv1_b.y - uv1_a.y)));
        float cos_theta = max(abs(dot(s.ng, dir)), 1e-3);
        if (world_area > 0.0) {
            lod_world = log2(cone_width / cos_theta) - 0.5 * log2(world_area);
        }
    }

    // Every texture goes through ONE sampling site in a non-unrolled loop: each inlined
    // textureLod costs lavapipe's JIT seconds, and the results are the same. A slot is read from
    // memory inside the loop, and beyond its texture index only when bound: on a CPU Vulkan
    // every component loaded costs one scalar load per SIMD lane, and the six slots are 48 of
    // the material's 69 components.
    MaterialBuf materials = MaterialBuf(scene.materials);
    vec4 texel[6];
    [[dont_unroll]] for (int k = 0; k < 6; ++k) {
        int tex = materials.v[g.material].textures[k].texture;
        texel[k] = vec4(1.0);
        if (tex >= 0 && uint(tex) < scene.texture_count) {
            texel[k] = sample_slot(materials.v[g.material].textures[k], uv0, uv1, lod_world, uv_areas);
        }
    }
    vec4 base = m.base_color * vcolor * texel[0];
    s.base_color = base.rgb;
    s.alpha = m.alpha_mode == ALPHA_OPAQUE ? 1.0 : base.a;
    s.alpha_mode = m.alpha_mode;
    s.metallic = clamp(m.metallic * texel[1].b, 0.0, 1.0);
    s.roughness = clamp(m.roughness * texel[1].g, 0.0, 1.0);
    s.emissive = m.emissive * texel[4].rgb;
    s.occlusion = 1.0 + m.occlusion_strength * (texel[3].r - 1.0);
    s.transmission = m.transmission * texel[5].r;
    s.ior = m.ior;
    s.atten_color = m.attenuation_color;
    s.atten_dist = m.thickness > 0.0 ? m.attenuation_distance : BIG_FLOAT;

    vec3 n_vertex = n;
    vec3 t = vec3(0.0), bt = vec3(0.0);
    if (m.textures[TEX_NORMAL].texture >= 0 && (g.flags & GEOMETRY_HAS_TANGENTS) != 0u) {
        vec4 t4 = w.x * verts.v[tri.x].tangent + w.y * verts.v[tri.y].tangent + w.z * verts.v[tri.z].tangent;
        t = mat3(inst.object_to_world) * t4.xyz;
        t = normalize(t - n * dot(n, t));
        bt = cross(n, t) * (t4.w < 0.0 ? -1.0 : 1.0);
        vec3 tn = texel[2].xyz * 2.0 - 1.0;
        tn.xy *= m.normal_scale;
        n = normalize(t * tn.x + bt * tn.y + n * tn.z);
    }
    s.n = s.front_face ? n : -n;
    surface_layers(s, m);
    if ((m.flags & MATERIAL_LAYERED) != 0u) {
        // The clearcoat has its own normal: the vertex normal, or its own normal map.
        s.clearcoat_n = s.front_face ? n_vertex : -n_vertex;
    }
    if ((m.flags & MATERIAL_EXT_TEXTURES) != 0u) {
        vec4 ext[8];
        [[dont_unroll]] for (int k = 0; k < 8; ++k) {
            int tex = materials.v[g.material].ext_textures[k].texture;
            ext[k] = vec4(1.0);
            if (tex >= 0 && uint(tex) < scene.texture_count) {
                ext[k] = sample_slot(materials.v[g.material].ext_textures[k], uv0, uv1, lod_world, uv_areas);
            }
        }
        s.specular *= ext[EXT_TEX_SPECULAR].a;
        s.specular_color *= ext[EXT_TEX_SPECULAR_COLOR].rgb;
        s.clearcoat *= ext[EXT_TEX_CLEARCOAT].r;
        s.clearcoat_roughness *= ext[EXT_TEX_CLEARCOAT_ROUGHNESS].g;
        s.sheen_color *= ext[EXT_TEX_SHEEN_COLOR].rgb;
        s.sheen_roughness *= ext[EXT_TEX_SHEEN_ROUGHNESS].a;
        // KHR_materials_volume: a thickness of 0 makes the material thin-walled.
        s.atten_dist = m.thickness * ext[EXT_TEX_THICKNESS].g > 0.0 ? m.attenuation_distance : BIG_FLOAT;
        if (m.ext_textures[EXT_TEX_CLEARCOAT_NORMAL].texture >= 0 && (g.flags & GEOMETRY_HAS_TANGENTS) != 0u) {
            vec3 tn = ext[EXT_TEX_CLEARCOAT_NORMAL].xyz * 2.0 - 1.0;
            tn.xy *= m.clearcoat_normal_scale;
            vec3 cn = normalize(t * tn.x + bt * tn.y + n_vertex * tn.z);
            s.clearcoat_n = s.front_face ? cn : -cn;
        }
    }
    return s;
}

// Radiance (per unit light radiance) arriving from light `l` at `p`: direction to the light,
// distance, and the attenuated radiance (inverse square, KHR range window, spot cone).
vec3 light_incidence(GpuLight l, vec3 p, out vec3 to_light, out float dist) {
    if (l.kind == LIGHT_DIRECTIONAL) {
        to_light = -l.direction;
        dist = BIG_FLOAT;
        return l.radiance;
    }
    vec3 d = l.position - p;
    float d2 = max(dot(d, d), 1e-12);
    dist = sqrt(d2);
    to_light = d / dist;
    float window = l.range < 1e30 ? pow(clamp(1.0 - pow(dist / l.range, 4.0), 0.0, 1.0), 2.0) : 1.0;
    vec3 e = l.radiance * window / d2;
    if (l.kind == LIGHT_SPOT) {
        float cd = dot(l.direction, -to_light);
        float t = clamp((cd - l.outer_cos) / max(l.inner_cos - l.outer_cos, 1e-4), 0.0, 1.0);
        e *= t * t;
    }
    return e;
}

#endif
