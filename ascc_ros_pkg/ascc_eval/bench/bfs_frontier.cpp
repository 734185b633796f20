// Baseline for scripts/bench_frontiers.py: a compiled breadth-first frontier search in the
// style of explore_lite's FrontierSearch, over a raw int8 occupancy grid (-1/0/100).
//   1. BFS (8-connected) from the robot cell over free cells (value 0),
//   2. every visited free cell with an unknown 8-neighbour is a frontier cell,
//   3. frontier cells are grouped by a second BFS (8-connected) into frontiers; each gets
//      its size, centroid and the BFS hop distance of its closest cell.
// Usage: bfs_frontier MAP.raw WIDTH HEIGHT ROBOT_COL ROBOT_ROW REPEAT
// Prints "frontiers=<n> cells=<n> best_ms=<t>"; t is the best of REPEAT runs, file I/O excluded.
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace {

struct Frontier {
  long size = 0;
  double sum_x = 0.0, sum_y = 0.0;
  int min_hops = 1 << 30;
};

const int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1};
const int kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};

std::vector<Frontier> search(const std::vector<int8_t>& grid, int w, int h, int rx, int ry,
                             long* frontier_cells) {
  const long n = static_cast<long>(w) * h;
  std::vector<int> hops(n, -1);
  std::vector<uint8_t> is_frontier(n, 0), grouped(n, 0);
  std::vector<long> queue;
  queue.reserve(1 << 20);
  std::vector<Frontier> out;
  *frontier_cells = 0;
  const long start = static_cast<long>(ry) * w + rx;
  if (grid[start] != 0) return out;
  hops[start] = 0;
  queue.push_back(start);
  for (size_t head = 0; head < queue.size(); ++head) {
    const long c = queue[head];
    const int x = static_cast<int>(c % w), y = static_cast<int>(c / w);
    for (int k = 0; k < 8; ++k) {
      const int nx = x + kDx[k], ny = y + kDy[k];
      if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
      const long nc = static_cast<long>(ny) * w + nx;
      if (grid[nc] == -1) is_frontier[c] = 1;
      if (grid[nc] == 0 && hops[nc] < 0) {
        hops[nc] = hops[c] + 1;
        queue.push_back(nc);
      }
    }
  }
  std::vector<long> group;
  for (long c : queue) {
    if (!is_frontier[c] || grouped[c]) continue;
    Frontier f;
    group.clear();
    group.push_back(c);
    grouped[c] = 1;
    for (size_t head = 0; head < group.size(); ++head) {
      const long g = group[head];
      const int x = static_cast<int>(g % w), y = static_cast<int>(g / w);
      f.size += 1;
      f.sum_x += x;
      f.sum_y += y;
      if (hops[g] < f.min_hops) f.min_hops = hops[g];
      for (int k = 0; k < 8; ++k) {
        const int nx = x + kDx[k], ny = y + kDy[k];
        if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
        const long nc = static_cast<long>(ny) * w + nx;
        if (is_frontier[nc] && !grouped[nc]) {
          grouped[nc] = 1;
          group.push_back(nc);
        }
      }
    }
    *frontier_cells += f.size;
    out.push_back(f);
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 7) {
    std::fprintf(stderr, "usage: %s MAP.raw WIDTH HEIGHT ROBOT_COL ROBOT_ROW REPEAT\n", argv[0]);
    return 2;
  }
  const int w = std::atoi(argv[2]), h = std::atoi(argv[3]);
  const int rx = std::atoi(argv[4]), ry = std::atoi(argv[5]), repeat = std::atoi(argv[6]);
  if (w <= 0 || h <= 0 || rx < 0 || ry < 0 || rx >= w || ry >= h || repeat <= 0) {
    std::fprintf(stderr, "bad arguments\n");
    return 2;
  }
  std::vector<int8_t> grid(static_cast<size_t>(w) * h);
  FILE* f = std::fopen(argv[1], "rb");
  if (!f || std::fread(grid.data(), 1, grid.size(), f) != grid.size()) {
    std::fprintf(stderr, "cannot read %s\n", argv[1]);
    return 2;
  }
  std::fclose(f);
  double best_ms = 1e30;
  size_t n_frontiers = 0;
  long cells = 0;
  for (int r = 0; r < repeat; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<Frontier> fr = search(grid, w, h, rx, ry, &cells);
    const auto t1 = std::chrono::steady_clock::now();
    const double ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
    if (ms < best_ms) best_ms = ms;
    n_frontiers = fr.size();
  }
  std::printf("frontiers=%zu cells=%ld best_ms=%.2f\n", n_frontiers, cells, best_ms);
  return 0;
}
