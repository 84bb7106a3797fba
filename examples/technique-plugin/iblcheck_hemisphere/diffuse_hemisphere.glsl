#ifdef DIFFUSE_HEMISPHERE
// Hemisphere lighting (sky_ground.py): E(n) = pi [ (1 + n.y) / 2 L_s + (1 - n.y) / 2 g L_g ], the exact
// irradiance of a uniform sky over a uniform ground; hemisphere_ground holds g L_g.
uniform vec3 hemisphere_sky;
uniform vec3 hemisphere_ground;

vec3 diffuse_irradiance(vec3 n) {
    float sky = 0.5 + 0.5 * n.y;
    return PI * (sky * hemisphere_sky + (1.0 - sky) * hemisphere_ground);
}
#endif
