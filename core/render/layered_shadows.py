"""Shadow rays in a layered scene (thesis 4.4): what a shown surface's light is blocked by. A
lower layer that a higher one covers casts no shadow (a surface that is not shown must not darken
the one shown over it), and neither does a poke-through the probe from its own side missed."""

import numpy as np

from ..geometry.vectors import rows
from ..rays.scene import RayHits, unit_rays


class ShadowRays:
    """LayeredScene's shadow queries (a base of it: they read its scene, layers, covers and probes)."""

    def blocked(self, origins, directions, max_dist, layered=True, leaving=None) -> np.ndarray:
        """Whether a shown surface lies on each ray before ``max_dist`` (shadow rays). With
        ``layered``, a lower layer that a higher one covers blocks nothing, and neither does a
        lower layer met within the probe distance of the higher-layer surface the ray leaves
        (``leaving``: per ray, the object it starts on, -1 for none): that is a poke-through
        the probe from its own side missed, and what is shown must not sit in its shadow."""
        # of length one once: every ray below is a piece of these, traced as they are
        origins, directions = unit_rays(origins, directions)
        out = self.scene.occluded(origins, directions, max_dist=max_dist, scaled=True)
        if not layered or not out.any():
            return out
        ask = np.flatnonzero(out)
        o, d = rows(origins, ask), rows(directions, ask)
        dist = np.broadcast_to(np.asarray(max_dist, float), out.shape)[ask].copy()
        # Anything nothing is worn over (the outermost layer, props) on the way is shown, so it
        # blocks: one occlusion ray settles the rays a stack of covered layers would otherwise
        # send round the layered loop.
        own = self.object_layer[np.full(len(out), -1) if leaving is None else np.asarray(leaving)][ask]
        uncovered = self._uncovered_scene(len(ask))
        if uncovered is not None:
            keep = ~uncovered.occluded(o, d, max_dist=dist, scaled=True)
            if keep.any():
                # of the rest, those with nothing on the way but poke-throughs are not blocked
                kept = np.flatnonzero(keep)
                free = self._clear_past_pokes(rows(o, kept), rows(d, kept), dist[kept], own[kept])
                out[ask[kept[free]]] = False
                keep[kept[free]] = False
            if not keep.any():
                return out
            keep = np.flatnonzero(keep)
            ask, o, d, dist, own = ask[keep], rows(o, keep), rows(d, keep), dist[keep], own[keep]
        travelled = np.zeros(len(ask))
        # rays whose first hit needs the layered test, from every round: traced on in one batch
        # at the end (the layered loop's rounds cost as much for a few rays as for many)
        pending = []
        for _ in range(4):
            # the cheap test first: a plain first hit on a lower layer this close is a poke-through
            hits = self.scene.intersect(o, d, max_dist=dist, scaled=True)
            obj, face = self.split(hits.face)
            layer = self.object_layer[obj]
            poke = hits.hit & (layer >= 0) & (layer < own)
            if poke.any():
                ids = np.flatnonzero(poke)
                reach = self.probe_at(obj[ids], face[ids], rows(hits.bary, ids))
                poke[ids] = travelled[ids] + hits.t[ids] <= reach
            out[ask[~hits.hit]] = False
            # a hit nothing is worn over (the outermost layer, props) blocks; one on a layer that
            # could be covered is traced the layered way
            rest = hits.hit & ~poke
            out[ask[rest & ~self._has_cover[layer]]] = True
            check = rest & self._has_cover[layer]
            if check.any():
                check = np.flatnonzero(check)
                pending.append((ask[check], rows(o, check), rows(d, check), dist[check], hits.t[check],
                                hits.face[check], rows(hits.bary, check)))
            if not poke.any():
                break
            poke = np.flatnonzero(poke)
            step = hits.t[poke] + self.eps
            d = rows(d, poke)
            ask, o, own = ask[poke], rows(o, poke) + d * step[:, None], own[poke]
            dist, travelled = dist[poke] - step, travelled[poke] + step
        else:
            out[ask] = False
        if pending:
            rays, o, d, dist, t, face, bary = (np.concatenate(x) for x in zip(*pending, strict=True))
            known = RayHits(t, face, bary, self.scene.normals_of)
            out[rays] = self.shown_from(known, o, d).t < dist
        return out

    def _clear_past_pokes(self, o, d, dist, own):
        """Which shadow rays, that nothing uncovered blocks, leaving a layer ``own`` meet nothing
        but poke-throughs: no covered layer as high as their own on the way, and nothing past
        the shortest probe distance of the layers under theirs (any of those met nearer is a
        poke-through). Two occlusion rays settle most rays the rounds would step past each
        poke-through with a closest hit at a time."""
        free = np.zeros(len(o), bool)
        for layer in np.unique(own):
            if layer not in self._past_pokes:
                self._past_pokes[layer] = self._poke_bounds(int(layer))
            higher, shortest = self._past_pokes[layer]
            if shortest is None:  # nothing under the layer: every hit is a blocker or a covered layer
                continue
            go = np.flatnonzero(own == layer)
            if higher is not None:
                go = go[~higher.occluded(rows(o, go), rows(d, go), max_dist=dist[go], scaled=True)]
            free[go] = ~self.scene.occluded(rows(o, go), rows(d, go), max_dist=dist[go], min_dist=shortest,
                                            scaled=True)
        return free

    def _poke_bounds(self, layer):
        """(ray scene of the covered layers from ``layer`` up, or None when there are none; the
        shortest probe distance of the layers under it, or None when there are none)."""
        under = [i for i, lay in enumerate(self.layers) if lay is not None and 0 <= lay < layer and len(self.faces[i])]
        if not under:
            return None, None
        higher = [i for i, lay in enumerate(self.layers)
                  if lay is not None and lay >= layer and self._has_cover[lay] and len(self.faces[i])]
        # a probe's l_s is blended from its triangle's corners: never shorter than the least of them
        shortest = min(float(self.probes[i][self.faces[i]].min()) for i in under)
        return (self._scene_of(higher) if higher else None), shortest


__all__ = ["ShadowRays"]
