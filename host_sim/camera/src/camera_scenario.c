/*
 * Random scenes for the camera command, the benchmark and the tests, and the
 * scoring of a pose_result against the renderer's ground truth.
 */
#include <math.h>
#include <string.h>

#include "camera/camera.h"

#define POSE_TRIES     1000
#define SPURIOUS_TRIES 500
#define VIEW_MARGIN_PX 5.0

static void normalise(double v[3]) {
    double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    v[0] /= n;
    v[1] /= n;
    v[2] /= n;
}

static void marker_centre(const struct camera_scene *s, size_t m, double c[3]) {
    const float *p = s->markers[m].position_mm;
    for (int i = 0; i < 3; ++i) {
        c[i] = s->pose.r[i][0] * (double)p[0] + s->pose.r[i][1] * (double)p[1] +
               s->pose.r[i][2] * (double)p[2] + s->pose.t[i];
    }
}

static int draw_pose(const struct camera_intrinsics *k, const struct camera_scenario *sc,
                     struct camera_rng *rng, struct camera_scene *scene) {
    for (int attempt = 0; attempt < POSE_TRIES; ++attempt) {
        scene->pose_draws = attempt + 1;
        double a = sc->max_angle_deg;
        double roll = camera_rng_uniform(rng, -a, a);
        double pitch = camera_rng_uniform(rng, -a, a);
        double yaw = camera_rng_uniform(rng, -a, a);
        double tz = sc->range_mm * camera_rng_uniform(rng, 0.98, 1.02);
        camera_pose_from_angles(roll, pitch, yaw, (const double[3]){0.0, 0.0, tz}, &scene->pose);
        if (sc->allow_partial) {
            /* Target origin within +-10 % of the half field of view. */
            scene->pose.t[0] = camera_rng_uniform(rng, -0.1, 0.1) * tz * k->cx / k->fx;
            scene->pose.t[1] = camera_rng_uniform(rng, -0.1, 0.1) * tz * k->cy / k->fy;
            return 0;
        }
        /* Offsets do not change marker depths, so each marker bounds tx and ty to an interval. */
        double lo[2] = {-INFINITY, -INFINITY};
        double hi[2] = {INFINITY, INFINITY};
        bool ok = true;
        for (size_t m = 0; m < scene->n_markers; ++m) {
            double c[3];
            marker_centre(scene, m, c);
            if (c[2] <= 0.5 * (double)scene->markers[m].diameter_mm) {
                ok = false;
                break;
            }
            double r_px = 0.5 * (double)scene->markers[m].diameter_mm * k->fx / c[2];
            double margin = r_px * 1.15 + VIEW_MARGIN_PX; /* 1.15: perspective growth */
            double f[2] = {k->fx, k->fy};
            double cc[2] = {k->cx, k->cy};
            double size[2] = {CAMERA_WIDTH, CAMERA_HEIGHT};
            for (int ax = 0; ax < 2; ++ax) {
                double l = (margin - cc[ax]) * c[2] / f[ax] - c[ax];
                double h = (size[ax] - 1.0 - margin - cc[ax]) * c[2] / f[ax] - c[ax];
                lo[ax] = fmax(lo[ax], l);
                hi[ax] = fmin(hi[ax], h);
            }
        }
        if (ok && lo[0] <= hi[0] && lo[1] <= hi[1]) {
            scene->pose.t[0] = camera_rng_uniform(rng, lo[0], hi[0]);
            scene->pose.t[1] = camera_rng_uniform(rng, lo[1], hi[1]);
            return 0;
        }
    }
    return -1;
}

static int place_spurious(const struct camera_intrinsics *k, const struct camera_scenario *sc,
                          struct camera_rng *rng, struct camera_scene *scene) {
    double placed_u[CAMERA_MAX_SPURIOUS];
    double placed_v[CAMERA_MAX_SPURIOUS];
    double placed_r[CAMERA_MAX_SPURIOUS];
    int n_placed = 0;
    double tz = scene->pose.t[2];
    for (int s = 0; s < sc->spurious; ++s) {
        bool done = false;
        for (int attempt = 0; attempt < SPURIOUS_TRIES && !done; ++attempt) {
            double u = camera_rng_uniform(rng, 12.0, CAMERA_WIDTH - 13.0);
            double v = camera_rng_uniform(rng, 12.0, CAMERA_HEIGHT - 13.0);
            double z = tz + camera_rng_uniform(rng, -250.0, -60.0);
            double a = camera_rng_uniform(rng, 8.0, 40.0);
            int kind = (int)(camera_rng_next(rng) % 3u); /* disc, elongated, two-disc cluster */
            double b = (kind == 1) ? a * camera_rng_uniform(rng, 0.2, 0.45) : a;
            double extent_px = ((kind == 2) ? 1.5 * a : a) * k->fx / z + 4.0;
            bool clear = z > 50.0;
            for (size_t m = 0; m < scene->n_markers && clear; ++m) {
                if (scene->hidden[m]) {
                    continue;
                }
                double c[3];
                marker_centre(scene, m, c);
                double mu = k->fx * c[0] / c[2] + k->cx;
                double mv = k->fy * c[1] / c[2] + k->cy;
                double mr = 1.15 * 0.5 * (double)scene->markers[m].diameter_mm * k->fx / c[2] + 4.0;
                clear = hypot(u - mu, v - mv) > extent_px + mr;
            }
            for (int j = 0; j < n_placed && clear; ++j) {
                clear = hypot(u - placed_u[j], v - placed_v[j]) > extent_px + placed_r[j];
            }
            if (!clear || scene->n_spurious + (kind == 2 ? 2u : 1u) > CAMERA_MAX_SPURIOUS) {
                continue;
            }
            struct camera_disc *d = &scene->spurious[scene->n_spurious++];
            d->centre[0] = z * (u - k->cx) / k->fx;
            d->centre[1] = z * (v - k->cy) / k->fy;
            d->centre[2] = z;
            d->normal[0] = camera_rng_uniform(rng, -0.5, 0.5);
            d->normal[1] = camera_rng_uniform(rng, -0.5, 0.5);
            d->normal[2] = -1.0;
            normalise(d->normal);
            /* In-plane axis: a random direction orthogonal to the normal. */
            double ang = camera_rng_uniform(rng, 0.0, 2.0 * 3.14159265358979);
            double ref[3] = {cos(ang), sin(ang), 0.0};
            double dn = ref[0] * d->normal[0] + ref[1] * d->normal[1];
            for (int i = 0; i < 3; ++i) {
                d->axis[i] = ref[i] - dn * d->normal[i];
            }
            normalise(d->axis);
            d->a = a;
            d->b = b;
            d->reflectance = camera_rng_uniform(rng, 0.6, 0.95);
            if (kind == 2) {
                struct camera_disc *e = &scene->spurious[scene->n_spurious++];
                *e = *d;
                for (int i = 0; i < 3; ++i) {
                    e->centre[i] = d->centre[i] + 0.9 * a * d->axis[i];
                }
                e->a = e->b = 0.6 * a;
            }
            placed_u[n_placed] = u;
            placed_v[n_placed] = v;
            placed_r[n_placed] = extent_px;
            ++n_placed;
            done = true;
        }
        if (!done) {
            return -1;
        }
    }
    return 0;
}

int camera_random_scene(const struct camera_intrinsics *k, const struct camera_scenario *sc,
                        struct camera_rng *rng, struct camera_scene *scene) {
    camera_scene_default(scene);
    if (draw_pose(k, sc, rng, scene) != 0) {
        return -1;
    }
    /* Hide `missing` distinct markers (partial Fisher-Yates). */
    size_t order[POSE_MAX_MARKERS];
    for (size_t m = 0; m < scene->n_markers; ++m) {
        order[m] = m;
    }
    for (int h = 0; h < sc->missing && (size_t)h < scene->n_markers; ++h) {
        size_t j = (size_t)h + (size_t)(camera_rng_next(rng) % (scene->n_markers - (size_t)h));
        size_t tmp = order[h];
        order[h] = order[j];
        order[j] = tmp;
        scene->hidden[order[h]] = true;
    }
    return place_spurious(k, sc, rng, scene);
}

void camera_evaluate(const struct camera_scene *scene, const struct camera_truth *truth,
                     const struct pose_result *res, struct camera_eval *ev) {
    memset(ev, 0, sizeof *ev);
    for (size_t m = 0; m < scene->n_markers; ++m) {
        if (truth->markers[m].visible) {
            ++ev->visible;
        }
    }
    for (size_t i = 0; i < res->n_blobs; ++i) {
        const struct pose_blob *b = &res->blobs[i];
        ev->blob_marker[i] = -1;
        double best = INFINITY;
        for (size_t m = 0; m < scene->n_markers; ++m) {
            const struct camera_marker_truth *mt = &truth->markers[m];
            if (!mt->in_scene) {
                continue;
            }
            double d = hypot((double)b->u_px - mt->ue, (double)b->v_px - mt->ve);
            double gate = fmax(1.5, 0.5 * mt->radius_px);
            if (d < gate && d < best) {
                best = d;
                ev->blob_marker[i] = (int)m;
            }
        }
        if (ev->blob_marker[i] >= 0) {
            const struct camera_marker_truth *mt = &truth->markers[ev->blob_marker[i]];
            ++ev->detected;
            double eu = (double)b->u_px - mt->ue;
            double evv = (double)b->v_px - mt->ve;
            double ru = (double)b->u_px - mt->u;
            double rv = (double)b->v_px - mt->v;
            ev->extract_sq += eu * eu + evv * evv;
            ev->raw_sq += ru * ru + rv * rv;
            ++ev->n_extract;
        }
    }
    ev->valid = res->status == POSE_STATUS_OK || res->status == POSE_STATUS_DEGRADED;
    if (!ev->valid) {
        return;
    }
    for (size_t j = 0; j < res->n_matches; ++j) {
        const struct pose_match_info *mi = &res->matches[j];
        if (ev->blob_marker[mi->blob] != (int)mi->marker) {
            ++ev->wrong;
            continue;
        }
        ++ev->matched_ok;
        const struct camera_marker_truth *mt = &truth->markers[mi->marker];
        double du = (double)mi->u_px - mt->u;
        double dv = (double)mi->v_px - mt->v;
        ev->final_sq += du * du + dv * dv;
        ++ev->n_final;
    }
    ev->correct = ev->wrong == 0;
    ev->complete = ev->correct && ev->matched_ok == ev->detected;
    ev->rot_err_deg = camera_rotation_error_deg(scene->pose.r, res->r);
    double dx = (double)res->t_mm[0] - scene->pose.t[0];
    double dy = (double)res->t_mm[1] - scene->pose.t[1];
    double dz = (double)res->t_mm[2] - scene->pose.t[2];
    ev->pos_err_mm = sqrt(dx * dx + dy * dy + dz * dz);
}
