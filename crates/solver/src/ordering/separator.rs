//! Maximum flow (Dinic), by which a bisection's cut edges become a minimum-weight vertex
//! separator.

/// Max flow by Dinic's algorithm (integer capacities), for the separator cover.
pub(super) struct Flow {
    head: Vec<usize>,
    next: Vec<usize>,
    to: Vec<usize>,
    cap: Vec<i64>,
}

impl Flow {
    const NONE: usize = usize::MAX;

    pub(super) fn new(nodes: usize) -> Flow {
        Flow {
            head: vec![Self::NONE; nodes],
            next: Vec::new(),
            to: Vec::new(),
            cap: Vec::new(),
        }
    }

    /// Adds `from → to` with capacity `cap` and its residual twin (edge index ^ 1).
    pub(super) fn add_edge(&mut self, from: usize, to: usize, cap: i64) {
        for (a, b, c) in [(from, to, cap), (to, from, 0)] {
            self.next.push(self.head[a]);
            self.head[a] = self.to.len();
            self.to.push(b);
            self.cap.push(c);
        }
    }

    fn levels(&self, source: usize) -> Vec<usize> {
        let mut level = vec![usize::MAX; self.head.len()];
        level[source] = 0;
        let mut queue = vec![source];
        let mut h = 0;
        while h < queue.len() {
            let v = queue[h];
            h += 1;
            let mut e = self.head[v];
            while e != Self::NONE {
                let u = self.to[e];
                if self.cap[e] > 0 && level[u] == usize::MAX {
                    level[u] = level[v] + 1;
                    queue.push(u);
                }
                e = self.next[e];
            }
        }
        level
    }

    pub(super) fn max_flow(&mut self, source: usize, sink: usize) {
        loop {
            let level = self.levels(source);
            if level[sink] == usize::MAX {
                return;
            }
            let mut it = self.head.clone();
            // Blocking flow: repeated depth-first searches along the level graph with an
            // explicit stack of edges (the paths can be long).
            loop {
                let mut path: Vec<usize> = Vec::new();
                let mut v = source;
                let found = loop {
                    if v == sink {
                        break true;
                    }
                    let mut advanced = false;
                    while it[v] != Self::NONE {
                        let e = it[v];
                        let u = self.to[e];
                        if self.cap[e] > 0 && level[u] == level[v] + 1 {
                            path.push(e);
                            v = u;
                            advanced = true;
                            break;
                        }
                        it[v] = self.next[e];
                    }
                    if !advanced {
                        // Dead end: retreat and skip the edge that led here.
                        match path.pop() {
                            Some(e) => {
                                v = self.to[e ^ 1];
                                it[v] = self.next[it[v]];
                            }
                            None => break false,
                        }
                    }
                };
                if !found {
                    break;
                }
                let push = path.iter().map(|&e| self.cap[e]).min().unwrap_or(0);
                for &e in &path {
                    self.cap[e] -= push;
                    self.cap[e ^ 1] += push;
                }
            }
        }
    }

    /// Nodes reachable from `source` in the residual network.
    pub(super) fn reachable(&self, source: usize) -> Vec<bool> {
        self.levels(source)
            .into_iter()
            .map(|l| l != usize::MAX)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn separator_is_a_minimum_weight_cover() {
        // Star: centre 0 (weight 1) joined to leaves 1..=4 (weight 3 each); centre on side 0,
        // leaves on side 1. The cheapest cover of the four cut edges is the centre.
        let mut f = Flow::new(7);
        for leaf in 1..=4 {
            f.add_edge(0, leaf, i64::MAX / 4);
            f.add_edge(leaf, 6, 3);
        }
        f.add_edge(5, 0, 1);
        f.max_flow(5, 6);
        let reach = f.reachable(5);
        assert!(
            !reach[0],
            "the centre is in the cover (cut from the source)"
        );
        assert!((1..=4).all(|l| !reach[l]), "no leaf is in the cover");
    }
}
