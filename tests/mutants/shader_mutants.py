"""Hand-made mutants of the real-time renderer's GLSL (and of the host code that feeds it), which mutation tools
cannot mutate: each one is applied alone to a scratch copy of the working tree, the GL tests run there, and the
mutant must make them fail ("caught"). `make shader-mutants`; not part of `make test` (it takes minutes).

    python tests/mutants/shader_mutants.py [--include-golden] [--list] [--tests PATH ...] [NAME_SUBSTRING ...]

Each entry is (file, exact original snippet, replacement, description). A snippet that is not found exactly once
in its file stops the script before anything runs (exit 2): the shader changed, so the list must be updated
with it (never silently skipped). The unmutated copy must pass the same tests first (exit 2 otherwise).

By default the golden-image test (tests/realtime/test_golden.py, bit-identical images of the paper's method) is
left out: it would catch every mutant without saying what is wrong, and the point is that the tests with an
independent expectation catch them. `--include-golden` runs it too.

Descriptions start with the technique ("irradiance map: ...", "prefiltered: ..."): the last lines count
the caught and surviving mutants per technique (the text before the first colon). `--tests` runs other
test paths than tests/realtime and tests/hard (a quick first pass on a technique's own tests: a mutant
caught there is caught by the full set, a survivor must be rerun on the full set before it is called one).

Exit status: 0 every mutant caught, 1 some survived, 2 the list or the baseline is broken.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

# (file, exact original snippet, replacement, description)
MUTANTS: list[tuple[str, str, str, str]] = [
    ("realtime/techniques/box/glossy_box.py", "rt.base_size, rt.lod_bias, rt.lod_mapping",
     "rt.base_size, 0.0, rt.lod_mapping",
     "ignore the LOD bias (host side: the glossy LOD reaches the shader as the uniform glossy_lod)"),
    ("realtime/techniques/box/glossy_box.glsl", "textureLod(env_cube, r, glossy_lod)", "textureLod(env_cube, r, 0.0)",
     "glossy lookup ignores its LOD (reads the base level)"),
    ("realtime/shaders/shade.frag", "if (dot(n, v) <= 0.0) {", "if (dot(n, v) <= -2.0) {",
     "drop the back-face rule (one-sided materials are black where n.v <= 0)"),
    ("realtime/shaders/shade.frag", "pow(1.0 - n_dot_v, 5.0)", "(1.0 - n_dot_v)",
     "drop the Fresnel power (Schlick's ^5)"),
    ("realtime/shaders/shade.frag", "color = (1.0 - F) * Ld + F * Lg;", "color = F * Ld + (1.0 - F) * Lg;",
     "swap the Fresnel weights of the two lobes"),
    ("realtime/shaders/shade.frag", "float F = f0 + (1.0 - f0) * pow(", "float F = (1.0 - f0) * pow(",
     "Schlick without its f0 term (F = 0 at normal incidence)"),
    ("realtime/shaders/shade.frag", "max(diffuse_irradiance(n), vec3(0.0))", "diffuse_irradiance(n)",
     "drop the max(E, 0) clamp of the SH irradiance"),
    ("realtime/shaders/shade.frag", "Ld = kd / PI * ", "Ld = kd * ", "diffuse without 1/pi"),
    ("realtime/shaders/shade.frag", "glossy_radiance(reflect(-v, n))", "glossy_radiance(reflect(v, n))",
     "reflect the wrong view vector"),
    ("realtime/shaders/sh_reduce.comp", "const float c1 = SH_M1, c2 = SH_M2,", "const float c1 = SH_M2, c2 = SH_M1,",
     "swap two SH constants (c1 <-> c2 of eq. 12)"),
    ("realtime/shaders/sh_reduce.comp", "c4 * L00 - c5 * L20", "c4 * L00 + c5 * L20",
     "sign of the c5 term of M[3][3]"),
    ("realtime/shaders/sh_project.comp", "c[1] += L * (SH_C1 * y);", "c[1] += L * (SH_C1 * x);",
     "SH basis Y1-1 on x instead of y"),
    ("realtime/shaders/sh_project.comp", "c[6] += L * (SH_C3 * (3.0 * z * z - 1.0));",
     "c[6] += L * (SH_C3 * (3.0 * y * y - 1.0));", "SH basis Y20 about y instead of z"),
    ("realtime/techniques/sh/diffuse_sh9.glsl", "vec4 n4 = vec4(n, 1.0);", "vec4 n4 = vec4(n, 0.0);",
     "n^T M n without the homogeneous 1 (drops the constant terms)"),
    ("realtime/shaders/common.glsl", "if (face == 4) return vec3(sc, -tc, 1.0);",
     "if (face == 4) return vec3(sc, tc, 1.0);", "flip a cube axis (+Z face, t)"),
    ("realtime/shaders/common.glsl", "if (face == 0) return vec3(1.0, -tc, -sc);",
     "if (face == 0) return vec3(1.0, -tc, sc);", "flip a cube axis (+X face, s)"),
    ("realtime/shaders/common.glsl", "float row = v * float(H - 1);", "float row = v * float(H) - 0.5;",
     "equirect rows as pixel centres instead of Mitsuba's align-corners"),
    ("realtime/shaders/env_to_cube.comp", "env_lookup_uv(env, uv.x + u_shift, uv.y)",
     "env_lookup_uv(env, uv.x - u_shift, uv.y)", "environment rotation with the wrong sign"),
    ("realtime/shaders/downsample.comp", "+ imageLoad(src, s + ivec3(0, 1, 0)) + imageLoad(src, s + ivec3(1, 1, 0));",
     "+ imageLoad(src, s + ivec3(1, 0, 0)) + imageLoad(src, s + ivec3(1, 1, 0));",
     "box filter reads one texel twice and skips another"),
    # the light array, its shadow maps and PRT
    ("realtime/techniques/lights/lights.glsl", "if (c > 0.0) E += light_power[i].rgb",
     "if (c > -1.0) E += light_power[i].rgb",
     "light array: lights below the surface's horizon count (negative cosines)"),
    ("realtime/techniques/lights/light_power.comp", ".rgb * row_omega[row];", ".rgb;",
     "light array powers without the texels' solid angles"),
    ("realtime/techniques/shadow_maps/shadow_maps.glsl", "    return 0.25 * v;", "    return 1.0;",
     "shadow maps never shadow"),
    ("realtime/techniques/prt/prt_vertex.glsl", "int base = gl_VertexID * SH_COUNT * 3;", "int base = 0;",
     "PRT: every vertex reads the first vertex's transfer"),
    ("realtime/techniques/prt/prt_vertex.glsl",
     "vec3(transfer[base + 3 * k], transfer[base + 3 * k + 1], transfer[base + 3 * k + 2])",
     "vec3(transfer[base + 3 * k + 2], transfer[base + 3 * k + 1], transfer[base + 3 * k])",
     "PRT: the transfer's colour channels read in reverse order"),
    ("realtime/techniques/prt/prt_vertex.glsl",
     "vec3(transfer[base + 3 * k], transfer[base + 3 * k + 1], transfer[base + 3 * k + 2])",
     "vec3(transfer[base + 3 * k])", "PRT: the red channel's transfer used for all three channels"),
    ("realtime/techniques/prt/prt.py", 'data = np.ascontiguousarray(t, dtype="f4")',
     'data = np.ascontiguousarray(t[..., ::-1], dtype="f4")',
     "PRT: the per-vertex transfer uploaded with its channels reversed (host side)"),
    # the irradiance map (brute-force cosine convolution)
    ("realtime/techniques/irradiance_map/irradiance_pack.comp",
     "packed_texels[2 * t] = texelFetch(weights, ivec2(x, y + f * source_size), 0);",
     "packed_texels[2 * t] = vec4(normalize(texelFetch(weights, ivec2(x, y + f * source_size), 0).xyz), 1.0);",
     "irradiance map: texel solid angles dropped (every source texel weighs the same)"),
    ("realtime/techniques/irradiance_map/irradiance_pack.comp", "texelFetch(weights, ivec2(x, y + f * source_size), 0)",
     "texelFetch(weights, ivec2(y, x + f * source_size), 0)",
     "irradiance map: the weights (direction, solid angle) fetched transposed"),
    ("realtime/techniques/irradiance_map/irradiance_pack.comp", "imageLoad(source, ivec3(x, y, f))",
     "imageLoad(source, ivec3(source_size - 1 - x, y, f))",
     "irradiance map: the packed radiance with x flipped on every face"),
    ("realtime/techniques/irradiance_map/irradiance_convolve.comp", "return e.rgb * (PI / max(e.a, 1e-30));",
     "return e.rgb / max(e.a, 1e-30);", "irradiance map: the normalised sum without its pi"),
    ("realtime/techniques/irradiance_map/irradiance_convolve.comp",
     "float sc = 2.0 * (float(g.x * B + b) + 0.5) / float(size) - 1.0;",
     "float sc = 2.0 * float(g.x * B + b) / float(size) - 1.0;",
     "irradiance map: output texel centres without +0.5 (s)"),
    ("realtime/techniques/irradiance_map/irradiance_convolve.comp", "anti[b] += max(-c, 0.0) * L;",
     "anti[b] += max(c, 0.0) * L;", "irradiance map: the antipode weighed by the cosine about n, not -n"),
    ("realtime/techniques/irradiance_map/irradiance_convolve.comp", "int y_anti = face == 2 ? g.y : size - 1 - g.y;",
     "int y_anti = face == 2 ? size - 1 - g.y : g.y;",
     "irradiance map: the opposite faces' rows mirrored on the wrong faces"),
    ("realtime/techniques/irradiance_map/irradiance_convolve.comp",
     "ivec3(face == 2 ? size - 1 - x : x, y_anti, face + 1)", "ivec3(x, y_anti, face + 1)",
     "irradiance map: the antipode on -Y written without mirroring x"),
    ("realtime/techniques/irradiance_map/irradiance_convolve.comp", "int face = 2 * g.z;  // +X, +Y, +Z",
     "int face = g.z;", "irradiance map: faces dispatched as 0, 1, 2 instead of +X, +Y, +Z"),
    ("realtime/techniques/irradiance_map/diffuse_irradiance_map.glsl", "textureLod(irradiance_cube, n, 0.0).rgb",
     "textureLod(irradiance_cube, vec3(n.xy, -n.z), 0.0).rgb", "irradiance map: looked up with the normal's z flipped"),
    ("realtime/techniques/irradiance_map/diffuse_irradiance_map.glsl", "textureLod(irradiance_cube, n, 0.0).rgb",
     "textureLod(irradiance_cube, n, 0.0).bgr", "irradiance map: red and blue swapped in the lookup"),
    # the Phong-prefiltered chain (host: the sample set; GLSL: the estimator and the lookup)
    ("realtime/techniques/prefiltered/prefilter.py", "math.log2((exponent + 1.0) / (2.0 * np.pi))",
     "math.log2(exponent + 1.0)", "prefiltered: the FIS pdf without its 1 / (2 pi)"),
    ("realtime/techniques/prefiltered/prefilter.py", "half_log2_ratio = 0.5 * (", "half_log2_ratio = (",
     "prefiltered: the FIS level without its 0.5 (log2 of the solid-angle ratio, not of the side ratio)"),
    ("realtime/techniques/prefiltered/prefilter.py", "omega_p = 4.0 * np.pi / (6.0 * base_size * base_size)",
     "omega_p = 4.0 * np.pi / (base_size * base_size)",
     "prefiltered: the base texel's solid angle without the 6 faces"),
    ("realtime/techniques/prefiltered/prefilter.py", "-np.expm1(log_xi1 / (exponent + 1.0))",
     "-np.expm1(log_xi1 / (exponent + 2.0))", "prefiltered: samples drawn from the lobe of exponent N + 1"),
    ("realtime/techniques/prefiltered/prefilter.py", "phi = 2.0 * np.pi * xi2", "phi = np.pi * xi2",
     "prefiltered: the samples' phi over only pi (half the lobe)"),
    ("realtime/techniques/prefiltered/prefilter_phong.comp", "float sc = 2.0 * (float(g.x) + 0.5) / float(size) - 1.0;",
     "float sc = 2.0 * float(g.x) / float(size) - 1.0;", "prefiltered: texel centres without +0.5 (s)"),
    ("realtime/techniques/prefiltered/prefilter_phong.comp", "clamp(s.w + bias, 0.0, max_lod)",
     "clamp(s.w - bias, 0.0, max_lod)", "prefiltered: the LOD bias with the wrong sign"),
    ("realtime/techniques/prefiltered/prefilter_phong.comp", "vec3 t2 = vec3(b, sgn + r.y * r.y * a, -r.y);",
     "vec3 t2 = vec3(b, sgn + r.y * r.y * a, r.y);", "prefiltered: the frame's t2 with the wrong z sign"),
    ("realtime/techniques/prefiltered/prefilter_phong.comp", "+ (1.0 - s.z) * r;", "+ s.z * r;",
     "prefiltered: the sample's z (stored as 1 - cos a) read as cos a"),
    ("realtime/techniques/prefiltered/prefilter_phong.comp", "vec4(sum / float(samples), 1.0)",
     "vec4(sum / float(samples - 1), 1.0)", "prefiltered: the sample mean divided by samples - 1"),
    ("realtime/techniques/prefiltered/glossy_prefiltered.py", "return int(math.floor(self.lods[exponent]))",
     "return int(math.ceil(self.lods[exponent]))",
     "prefiltered: the first level prefiltered rounded up (the level below the LOD left unwritten)"),
    ("realtime/techniques/prefiltered/glossy_prefiltered.glsl", "textureLod(prefiltered_cube, r, prefiltered_lod)",
     "textureLod(prefiltered_cube, r, floor(prefiltered_lod))",
     "prefiltered: the lookup at the integer level below the LOD (no interpolation between levels)"),
    # the 2D environment parameterizations (dual paraboloid, sphere map)
    ("realtime/shaders/env_map.glsl", "return vec4(p, d.z >= 0.0 ? 0.0 : 1.0, 4.0 / (q * q));",
     "return vec4(p, d.z >= 0.0 ? 1.0 : 0.0, 4.0 / (q * q));", "paraboloid: the hemispheres' layers swapped"),
    ("realtime/shaders/env_map.glsl", "vec2 p = d.xy / (1.0 + abs(d.z));", "vec2 p = d.xy / (1.0 + d.z);",
     "paraboloid: the back hemisphere projected with the front's sign"),
    ("realtime/shaders/env_map.glsl", "4.0 / (q * q)", "4.0 / q",
     "paraboloid: dOmega/dA with (1 + r^2) instead of its square"),
    ("realtime/shaders/env_map.glsl", "float len = length(vec3(d.xy, d.z + 1.0));",
     "float len = length(vec3(d.xy, d.z - 1.0));", "sphere map: the pole on the wrong side (a view along +z)"),
    ("realtime/shaders/env_map.glsl", "env_map_position(env_frame * normalize(r))",
     "env_map_position(transpose(env_frame) * normalize(r))",
     "sphere map: the capture frame transposed in the lookup (map -> world)"),
    ("realtime/engine/environment_maps.py", 'prog["env_frame"].write(mat_bytes(self.frame))',
     'prog["env_frame"].write(mat_bytes(self.frame.T))',
     "sphere map: the capture frame uploaded transposed (host side)"),
    ("realtime/engine/environment_maps.py", "return self.mapping.texel_directions(size) @ self.frame",
     "return self.mapping.texel_directions(size) @ self.frame.T",
     "sphere map: the texels' world directions with the capture frame transposed (host side: fill and SH)"),
    ("realtime/shaders/env_map.glsl", "- 0.5 * log2(m.w)", "+ 0.5 * log2(m.w)",
     "env map: the density's LOD correction with the wrong sign"),
    ("realtime/shaders/env_map.glsl", "vec3(0.5 * m.xy + 0.5, m.z)", "vec3(0.5 * vec2(m.x, -m.y) + 0.5, m.z)",
     "env map: the lookup's v flipped (rows top-down)"),
    ("realtime/shaders/map_fill.comp", "env_lookup_uv(env, uv.x + u_shift, uv.y)",
     "env_lookup_uv(env, uv.x - u_shift, uv.y)", "env map: the 2D fill rotates the environment the wrong way"),
    ("realtime/shaders/map_fill.comp", "texelFetch(texel_uv, g, 0).rg", "texelFetch(texel_uv, g, 0).gr",
     "env map: the 2D fill's u and v swapped"),
    ("realtime/shaders/map_downsample.comp",
     "+ imageLoad(src, s + ivec3(0, 1, 0)) + imageLoad(src, s + ivec3(1, 1, 0));",
     "+ imageLoad(src, s + ivec3(1, 0, 0)) + imageLoad(src, s + ivec3(1, 1, 0));",
     "env map: the 2D box filter reads one texel twice and skips another"),
    ("realtime/shaders/map_downsample.comp", "ivec3 s = ivec3(2 * g.xy, g.z);", "ivec3 s = ivec3(2 * g.xy, 0);",
     "paraboloid: every layer's mip level made from the first layer"),
    ("realtime/shaders/map_sh_project.comp", "vec3 L = imageLoad(level, t).rgb * dw.w;",
     "vec3 L = imageLoad(level, t).rgb;", "env map: SH projection without the texels' solid angles"),
    ("realtime/shaders/map_sh_project.comp", "texelFetch(texel_dir, ivec2(t.x, t.y + t.z * size), 0)",
     "texelFetch(texel_dir, ivec2(t.x, t.y), 0)",
     "paraboloid: SH projection with the first layer's directions for both layers"),
    ("realtime/engine/environment_maps.py", "return spheremap.capture_frame(forward, cam.up)",
     "return spheremap.capture_frame(forward, cam.up).T", "sphere map: the capture frame transposed everywhere"),
    # the light array's glossy lobe and the shadow maps' filter
    ("realtime/techniques/lights/lights.glsl", "float norm = (phong_exponent + 1.0) / (2.0 * PI);",
     "float norm = (phong_exponent + 2.0) / (2.0 * PI);",
     "light array: glossy lobe normalised by (N + 2)/(2 pi) instead of the paper's (N + 1)/(2 pi)"),
    ("realtime/techniques/lights/lights.glsl", "exp(phong_exponent * log(c))", "exp((phong_exponent + 1.0) * log(c))",
     "light array: glossy lobe cos^(N+1) under the (N + 1)/(2 pi) normalisation"),
    ("realtime/techniques/lights/lights.glsl", "if (c <= 0.0 || dot(shading_normal, l) <= 0.0) continue;",
     "if (c <= 0.0) continue;", "light array: glossy lobe counts lights below the surface's horizon"),
    ("realtime/techniques/lights/lights.glsl", "float lobe = phong_exponent == 0.0 ? 1.0 : ",
     "float lobe = phong_exponent == 0.0 ? 0.5 : ", "light array: the uniform glossy lobe (N = 0) halved"),
    ("realtime/techniques/shadow_maps/shadow_maps.glsl", "    return 0.25 * v;", "    return min(v, 1.0);",
     "shadow maps: PCF lights a pixel fully when any tap is lit"),
    # voxel cone tracing: the face a cone reads, the footprint cap, the accumulation, the injection
    ("realtime/techniques/vct/vct_trace.glsl",
     "d.x > 0.0 ? vct_fetch(vct_face_nx, local, c, mip) : vct_fetch(vct_face_px, local, c, mip)",
     "d.x > 0.0 ? vct_fetch(vct_face_px, local, c, mip) : vct_fetch(vct_face_nx, local, c, mip)",
     "VCT: a cone reads the +X/-X faces swapped"),
    ("realtime/techniques/vct/vct_trace.glsl", "vec4 z = d.z > 0.0 ?", "vec4 z = d.z < 0.0 ?",
     "VCT: the z sign test of the face a cone reads flipped"),
    ("realtime/techniques/vct/vct_trace.glsl",
     "d.y > 0.0 ? vct_fetch(vct_face_ny, local, c, mip) : vct_fetch(vct_face_py, local, c, mip)",
     "d.y > 0.0 ? vct_fetch(vct_face_py, local, c, mip) : vct_fetch(vct_face_ny, local, c, mip)",
     "VCT: a cone reads the +Y/-Y faces swapped"),
    ("realtime/techniques/vct/vct_trace.glsl", "/ n1 - vct_voxel) / 1.5;", "/ n1 - vct_voxel) / 0.75;",
     "VCT: footprint cap with the trilinear reach taken as 0.75 texel"),
    ("realtime/techniques/vct/vct_trace.glsl", "float s_max = (dot(p - surface, n) / n1 - vct_voxel)",
     "float s_max = (dot(p - surface, n) - vct_voxel)", "VCT: footprint cap ignores |n|_1 of a tilted surface"),
    ("realtime/techniques/vct/vct_trace.glsl", "float lod = max(min(lod_cone, lod_cap), lod_min);",
     "float lod = max(lod_cone, lod_min);", "VCT: no footprint cap on the level"),
    ("realtime/techniques/vct/vct_trace.glsl", "float lod_cap = floor(log2(", "float lod_cap = ceil(log2(",
     "VCT: footprint cap rounded up"),
    ("realtime/techniques/vct/vct_trace.glsl", "max(2.0 * t * tan_half, vct_voxel)", "max(t * tan_half, vct_voxel)",
     "VCT: the cone's radius taken for its diameter"),
    ("realtime/techniques/vct/vct_trace.glsl", "vec3 rgb = a0 > 1e-6 ? s.rgb * (a / a0) : vec3(0.0);",
     "vec3 rgb = s.rgb;", "VCT: radiance not rescaled with the Beer-Lambert opacity"),
    ("realtime/techniques/vct/vct_trace.glsl", "acc.rgb += (1.0 - acc.a) * rgb;", "acc.rgb += rgb;",
     "VCT: radiance composited without the transmittance"),
    ("realtime/techniques/vct/vct_trace.glsl", "return vec4(E, V / 3.14159265358979323846);",
     "return vec4(E, V / 3.0);", "VCT: visibility normalised by 3 instead of pi"),
    ("realtime/techniques/vct/vct_trace.glsl", "float a0 = clamp(front > 1e-6 ? front : s.a, 0.0, 1.0);",
     "float a0 = clamp(s.a, 0.0, 1.0);", "VCT: a surface's back faces counted in the radiance's normalisation"),
    ("realtime/techniques/vct/vct_mip.comp", "front_alpha += is_back ? 0.0 : pair_alpha;",
     "front_alpha += pair_alpha;", "VCT: the mip's back pairs counted in its radiance's normalisation"),
    ("realtime/techniques/vct/vct_mip.comp",
     "vec3 orgb = load_opposite(far).rgb + (1.0 - opposite_alpha_at(far)) * load_opposite(near).rgb;",
     "vec3 orgb = load_opposite(near).rgb + (1.0 - opposite_alpha_at(near)) * load_opposite(far).rgb;",
     "VCT: the mip's opposite pair composited in this face's order"),
    ("realtime/techniques/vct/vct_mip.comp", "out_.rgb = sum.rgb * (out_.a / front_alpha)",
     "out_.rgb = 0.25 * sum.rgb * (out_.a / front_alpha)", "VCT: the mip's radiance not rescaled"),
    ("realtime/techniques/vct/vct_trace.glsl",
     "return rho_ref > 0.0 ? clamp(vct_rho(against) / rho_ref, 0.0, 1.0) : 1.0;", "return 1.0;",
     "VCT: a face lit both ways counts whole in the normalisation"),
    ("realtime/techniques/vct/vct_trace.glsl",
     "float rho_ref = wa.x >= wa.y && wa.x >= wa.z ? vct_rho(x) : (wa.y >= wa.z ? vct_rho(y) : vct_rho(z));",
     "float rho_ref = max(vct_rho(x), max(vct_rho(y), vct_rho(z)));",
     "VCT: the brightest face as the normalisation's reference"),
    ("realtime/techniques/vct/vct_trace.glsl", "    if (b <= 0.0) return 1.0;\n", "\n",
     "VCT: fronts whose opposite face is black discounted"),
    ("realtime/techniques/vct/vct_trace.glsl", "return facing < 0.0 ? vec4(0.0, 0.0, 0.0, opacity) :",
     "return false ? vec4(0.0, 0.0, 0.0, opacity) :",
     "VCT: a texel showing a cone a two-sided wall's dark side adds the light behind it"),
    ("realtime/techniques/vct/vct_trace.glsl", "return dot(m, m) > VCT_NORMAL_EPS * VCT_NORMAL_EPS ? -1.0 : 0.0;",
     "return -1.0;",
     "VCT: a one-sided surface's back counted as a wall's dark side in the facing sum"),
    ("realtime/techniques/vct/vct_trace.glsl",
     "vec3 sees = vec3(lessThan(vec3(dot(mx, d), dot(my, d), dot(mz, d)), vec3(-VCT_NORMAL_EPS)));",
     "vec3 sees = vec3(1.0);", "VCT: a face adds light whichever way its surfaces face"),
    ("realtime/techniques/vct/vct_trace.glsl", "int c = clamp(int(floor(lod - mip_floor)), inside,",
     "int c = clamp(int(floor(lod)), inside,",
     "VCT: the bounce passes' cones pick the cascade as the shading's do, reading a coarser level than the cone's"),
    ("realtime/techniques/vct/vct_trace.glsl", "mip = clamp(max(lod - float(c), mip_floor), 0.0,",
     "mip = clamp(lod - float(c), 0.0,",
     "VCT: the bounce passes' cones read level 0 of the coarse cascade a sample lies in, which those passes rewrite"),
    ("realtime/techniques/vct/vct_trace.glsl", "i < vct_max_samples && acc.a < 0.995", "i < 512 && acc.a < 0.995",
     "VCT: cones stop after a fixed 512 samples, short of what a grazing cone needs to leave the cascades"),
    ("realtime/techniques/vct/vct_normal_mip.comp", "ivec3 pf = sign_ > 0 ? p + e : p;",
     "ivec3 pf = sign_ > 0 ? p : p + e;", "VCT: the normals' mip composited in the opposite face's order"),
    ("realtime/techniques/vct/vct_inject.comp", "L[f] += (1.0 - F) * kd / PI * done_E[k].rgb;",
     "L[f] += (1.0 - F) * kd * done_E[k].rgb;", "VCT: injection without 1/pi"),
    ("realtime/techniques/vct/vct_inject.comp", "put(f, q, cover[f / 2] * vec4(L[f] * vct_radiance_scale, 1.0));",
     "put(f, q, vec4(L[f] * vct_radiance_scale, 1.0));",
     "VCT: every face opaque, whatever its surfaces' coverage along its axis"),
    ("realtime/techniques/vct/vct_trace.glsl", "return vec4(acc.rgb / vct_radiance_scale, acc.a);",
     "return acc;", "VCT: the cones return the faces' scaled radiance, not the scene's"),
    ("realtime/techniques/vct/vct_inject.comp", "            G[f] = F * ks * lobe.a;\n",
     "            G[f] = vec3(0.0);\n            L[f] += F * ks / PI * irradiance(n);\n",
     "VCT: a glossy surface injected as if diffuse"),
    ("realtime/techniques/vct/vct_inject.comp", "G[f] = F * ks * lobe.a;", "G[f] = F * ks;",
     "VCT: the injected glossy lobe without its cone's visibility"),
    ("realtime/techniques/vct/vct_inject.comp", "L[f] += F * ks * vct_lobe_above(c, N) * lobe.rgb;",
     "L[f] += vec3(0.0);", "VCT: the injected glossy bounce dropped"),
    ("realtime/techniques/vct/vct_inject.comp", "vec3 r = reflect(-a, n);", "vec3 r = n;",
     "VCT: the injected glossy lobe about the normal instead of the mirror direction"),
    ("realtime/techniques/vct/vct_glossy_env.glsl", "log2(vct_env_base_size * sqrt(3.0)) - 0.5 * log2(N + 1.0)",
     "log2(vct_env_base_size * sqrt(3.0))", "VCT: the chain level of the glossy lobe ignores the Phong exponent"),
    ("realtime/techniques/vct/vct_glossy_env.glsl", "vec4 t = textureLod(vct_env_cube, r, clamp",
     "vec4 t = textureLod(vct_env_cube, vec3(-r.x, r.yz), clamp",
     "VCT: the glossy lobe's chain looked up with x mirrored"),
    ("realtime/techniques/vct/vct_glossy_env.glsl", "return t.rgb / max(t.a, 1e-30);", "return t.rgb;",
     "VCT: the chain weighted by solid angle read without dividing its weight out"),
    ("realtime/techniques/vct/lobe_table.py", 'set_uniform(self.prog, "exponent", float(exponent))',
     'set_uniform(self.prog, "exponent", float(exponent) + 1.0)',
     "VCT: the broad-lobe table's layers one exponent sharper than their read (host side)"),
    ("realtime/techniques/vct/vct_lobe_table.comp", "float w = t.w * pow(c, N);", "float w = pow(c, N);",
     "VCT: the broad-lobe table's quadrature without the texels' solid angles"),
    ("realtime/techniques/vct/vct_lobe_table.comp", "sum += w * L.rgb / max(L.a, 1e-30);", "sum += w * L.rgb;",
     "VCT: the broad-lobe table sums the weighted chain without dividing its weight out"),
    ("realtime/techniques/vct/vct_lobe_axis.glsl", "atan(d.x, -d.z)", "atan(d.x, d.z)",
     "VCT: the broad-lobe table read with its azimuth mirrored"),
    ("realtime/techniques/vct/vct_glossy_env.glsl", "- (x + 1.0) * x * (x - 2.0) / 2.0 * vct_lobe_layer(uv, m + 1.0)",
     "+ (x + 1.0) * x * (x - 2.0) / 2.0 * vct_lobe_layer(uv, m + 1.0)",
     "VCT: the broad-lobe table's cubic read across layers with a third weight of the wrong sign"),
    ("realtime/techniques/vct/vct_glossy_env.glsl", "mix(table, vct_chain_env(r, N), past)",
     "mix(vct_chain_env(r, N), table, past)", "VCT: the broad-lobe table's blend into the chain the wrong way round"),
    ("realtime/techniques/vct/vct_glossy_env.glsl", "float past = clamp(j - (VCT_LOBE_LAYERS - 1.0), 0.0, 1.0);",
     "float past = 1.0;", "VCT: the broad-lobe table left unread (the chain alone)"),
    ("realtime/shaders/solid_angle_weight.comp", "vec4(imageLoad(src, g).rgb * w, w)",
     "vec4(imageLoad(src, g).rgb, 1.0)", "VCT: the chain weighted by solid angle left unweighted (the box chain)"),
    ("realtime/techniques/vct/vct_trace.glsl", "mip), my, vct_normal_mean_length(smy), -d, cone_mean_cos);",
     "mip), my, vct_normal_mean_length(smy), d, cone_mean_cos);",
     "VCT: the deferred glossy read evaluates a face against the cone toward the cone's own direction"),
    ("realtime/techniques/vct/vct_trace.glsl", "vct_glossy_env(reflect(-v, n), vct_broadened_exponent(",
     "vct_glossy_env(reflect(v, n), vct_broadened_exponent(", "VCT: the deferred glossy read reflects the wrong way"),
    ("realtime/techniques/vct/vct_trace.glsl",
     "float cone_mean_cos = 0.5 * (1.0 + inversesqrt(1.0 + tan_half * tan_half));", "float cone_mean_cos = 1.0;",
     "VCT: the deferred glossy read takes the lobe about the cone's axis alone, not over its aperture"),
    ("realtime/techniques/vct/vct_trace.glsl", "return max(2.0 * mean_length * mean_length - 1.0, 0.0);",
     "return 1.0;", "VCT: the deferred glossy read ignores the spread of the normals a face stands for"),
    ("realtime/techniques/vct/vct_trace.glsl", "return max(2.0 * mean_length * mean_length - 1.0, 0.0);",
     "return mean_length;", "VCT: the normals' spread turns the mirrors by theta, not 2 theta"),
    ("realtime/techniques/vct/vct_normal_mip.comp", "spread += af * vct_normal_mean_length(sf) * normalize(nf);",
     "spread += af * normalize(nf);", "VCT: the normals' mip forgets the spread its children already hold"),
    ("realtime/techniques/vct/vct_normal_mip.comp", "clamp(dot(spread, m / len) / held, 0.0, 1.0)",
     "clamp(dot(spread, m / len) / 4.0, 0.0, 1.0)",
     "VCT: the normals' spread divided by the children's count, not by the weights of those holding a normal"),
    ("realtime/techniques/vct/vct_normal_mip.comp", "clamp(dot(spread, m / len) / held, 0.0, 1.0)",
     "clamp(length(spread) / held, 0.0, 1.0)",
     "VCT: the normals' spread taken about their mean, not the stored normal"),
    ("realtime/techniques/vct/vct_normals.comp", "min(length(ns) / weights + rounding, 1.0)",
     "min(length(ns) / weights, 1.0)", "VCT: the voxeliser's rounding read as the normals' spread"),
    ("realtime/techniques/vct/vct_trace.glsl", "g.rgb * (vct_lobe_above(c, N) * vct_radiance_scale)",
     "g.rgb * vct_radiance_scale", "VCT: the deferred glossy read without the lobe's share above the horizon"),
    ("realtime/techniques/vct/vct_trace.glsl", "float N = clamp(g.a / weight, 0.0, VCT_MAX_EXPONENT);",
     "float N = 1.0;", "VCT: the deferred glossy read loses the exponent"),
    ("realtime/techniques/vct/vct_inject.comp", "&& (f0 > 0.0 || schlick > 0.0);", "&& (f0 > 1.0 || schlick > 0.0);",
     "VCT: a Phong surface's glossy term skipped in the injection"),
    ("realtime/techniques/split_sum/prefilter_ggx.comp", "* n_dot_l;\n        weight += n_dot_l;",
     ";\n        weight += 1.0;", "split sum: the prefilter's samples not weighted by n.l"),
    ("realtime/techniques/split_sum/glossy_split_sum.glsl", "textureLod(split_sum_level_hi, r, 0.0).rgb, split_sum_t)",
     "textureLod(split_sum_level_hi, r, 0.0).rgb, 1.0 - split_sum_t)", "split sum: the two levels' mix swapped"),
    ("realtime/techniques/split_sum/glossy_split_sum.glsl", "vec3 F_avg = F0 + (1.0 - F0) / 21.0;\n    return FssEss",
     "vec3 F_avg = F0 + (1.0 - F0) / 20.0;\n    return FssEss", "split sum: Fdez-Aguera's F_avg with /20"),
    ("realtime/techniques/split_sum/glossy_split_sum.glsl", "split_sum_fresnel(vec3(PBR_DIELECTRIC_F0), n_dot_v)",
     "split_sum_fresnel(base_color, n_dot_v)", "split sum: the dielectric's F0 taken from base_color"),
    ("realtime/shaders/shade.frag", "split_sum_lobes(n_dot_v, base_color / PI * E, G, Ld, Lg);",
     "split_sum_lobes(n_dot_v, base_color * E, G, Ld, Lg);", "split sum: the Lambert term without 1/pi"),
    ("realtime/techniques/split_sum/glossy_split_sum.glsl", "Ld = (1.0 - metallic) * (1.0 - F_d) * diffuse;",
     "Ld = (1.0 - metallic) * diffuse;", "split sum: the dielectric's diffuse not weighted by 1 - F"),
]

GL_TESTS = ["tests/realtime", "tests/hard"]
GOLDEN = "tests/realtime/test_golden.py"


def copy_tree(dst: Path) -> None:
    """Tracked and untracked, not ignored files of the working tree (what the tests see)."""
    files = subprocess.run(["git", "ls-files", "-co", "--exclude-standard", "-z"], cwd=ROOT, check=True,
                           capture_output=True).stdout.decode().split("\0")
    for name in filter(None, files):
        src = ROOT / name
        if src.is_file():
            (dst / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dst / name)


def check_snippets(mutants) -> list[str]:
    problems = []
    for file, old, _, desc in mutants:
        path = ROOT / file
        count = path.read_text().count(old) if path.is_file() else -1
        if count != 1:
            where = "file missing" if count < 0 else f"found {count} times"
            problems.append(f"{file}: {desc}: snippet {old!r} {where}")
    return problems


def technique(desc: str) -> str:
    """The group of a mutant: its description up to the first colon ("other" without one)."""
    head, colon, _ = desc.partition(":")
    return head.strip() if colon else "other"


def run_tests(copy: Path, include_golden: bool, stop_at_first: bool,
              tests: list[str] = GL_TESTS) -> tuple[int, str, float]:
    args = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-m", "gl and not slow", *tests]
    if not include_golden:
        args.append(f"--ignore={GOLDEN}")
    if stop_at_first:
        args.append("-x")
    env = {**os.environ, "PYTHONPATH": str(copy)}
    t0 = time.perf_counter()
    out = subprocess.run(args, cwd=copy, env=env, capture_output=True, text=True)
    lines = [line for line in out.stdout.strip().splitlines() if line.strip()]
    failed = [line.split(" - ")[0].removeprefix("FAILED ") for line in lines if line.startswith("FAILED ")]
    summary = (failed[0] + " ... " if failed else "") + (lines[-1] if lines else out.stderr.strip()[-300:])
    return out.returncode, summary, time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", help="run only mutants whose description contains one of these")
    parser.add_argument("--include-golden", action="store_true", help="also run the golden-image test")
    parser.add_argument("--list", action="store_true", help="list the mutants and check their snippets")
    parser.add_argument("--tests", nargs="+", default=GL_TESTS, metavar="PATH",
                        help="test paths to run instead of tests/realtime and tests/hard")
    args = parser.parse_args(argv)
    mutants = [m for m in MUTANTS if not args.names or any(n in m[3] for n in args.names)]
    problems = check_snippets(mutants)
    if problems:
        print("error: the mutant list no longer matches the code; update tests/mutants/shader_mutants.py:",
              *problems, sep="\n  ", file=sys.stderr)
        return 2
    if args.list:
        for file, old, new, desc in mutants:
            print(f"{desc}\n    {file}: {old!r} -> {new!r}")
        return 0
    with tempfile.TemporaryDirectory(prefix="shader-mutants-") as tmp:
        copy = Path(tmp)
        copy_tree(copy)
        where = subprocess.run([sys.executable, "-c", "import realtime; print(realtime.__file__)"], cwd=copy,
                               env={**os.environ, "PYTHONPATH": str(copy)}, capture_output=True, text=True)
        if not where.stdout.strip().startswith(str(copy)):
            print(f"error: the copy's tests would import realtime from {where.stdout.strip() or where.stderr}",
                  file=sys.stderr)
            return 2
        code, summary, secs = run_tests(copy, args.include_golden, stop_at_first=False, tests=args.tests)
        print(f"baseline (no mutant): {summary} [{secs:.0f} s]")
        if code != 0:
            print("error: the unmutated code fails these tests; fix that first", file=sys.stderr)
            return 2
        survived = []
        for file, old, new, desc in mutants:
            path = copy / file
            original = path.read_text()
            path.write_text(original.replace(old, new))
            try:
                code, summary, secs = run_tests(copy, args.include_golden, stop_at_first=True, tests=args.tests)
            finally:
                path.write_text(original)
            verdict = "caught" if code == 1 else "SURVIVED" if code == 0 else f"error (pytest exit {code})"
            if code == 0:
                survived.append(desc)
            print(f"{verdict:>9}  {desc}  [{file}; {secs:.0f} s]\n           {summary}")
        print(f"\n{len(mutants) - len(survived)} of {len(mutants)} shader mutants caught")
        groups = sorted({technique(m[3]) for m in mutants})
        for group in groups:
            total = sum(technique(m[3]) == group for m in mutants)
            lost = sum(technique(desc) == group for desc in survived)
            print(f"  {group}: {total - lost} of {total} caught" + (f", {lost} survived" if lost else ""))
        return 1 if survived else 0


if __name__ == "__main__":
    sys.exit(main())
