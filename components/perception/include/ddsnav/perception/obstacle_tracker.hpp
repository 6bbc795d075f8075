#pragma once
// Keeps obstacles across scans, on evidence: every track owns a bounded set of voxel centroids
// (world frame, one per evidence cell: voxel_size in 2-D, voxel_size_3d in 3-D) and its ellipse/ellipsoid
// is refitted from them with the same Gaussian + sensor noise + chi-square model as a detection. Ids are stable; the set grows as the
// vehicle discovers the world, and shrinks as it leaves tracks behind beyond forget_radius.
//
//   ObstacleTracker tracker(TrackerParams::matching(detector_params));
//   for (each cloud) { auto& world = tracker.update(detector.detect(cloud.points, cloud.origin), cloud.origin); }
//
// Association is per voxel of a detection's `support`, never by overlapping ellipses:
//   1. a voxel whose cell a track already owns refreshes that track's centroid there (running mean);
//   2. a voxel in a new cell joins the track that owns the nearest voxel within
//      association_distance (the same physical surface, as the Euclidean clustering defines it),
//      but only while that track's voxels stay inside a box of side max_segment_length (and width
//      max_segment_width along the thinnest axis) in the track's own frame (the principal axes of
//      the voxels it started from) — the rule the detector cuts pieces by (pieceTooBig);
//      if the nearest track is full, the next nearest within the distance is tried;
//   3. the remaining voxels are grouped by the same distance, cut by splitByExtent, and each piece
//      starts a new track.
// So a track's evidence never leaves its box: a track cannot run away over neighbouring obstacles
// or free space, however long the drive (see docs/perception.md).
//
// Cost follows what changed, not what exists: a track whose evidence grew is refitted in the same
// update; a track whose voxels were only refreshed keeps its ellipse while every refreshed voxel
// (pushed outward by its position uncertainty, as the fit does) is still inside it, and is refitted
// at most max_refit_delay updates later (oldest first, at most max_deferred_refits per update).
// Association never reads the ellipses, so the evidence is exactly what refitting every change
// (max_refit_delay = 0, the reference behaviour) gives, and no seen voxel is ever outside its ellipse.
//
// State stays bounded: update(detections, sensor_origin) first forgets every track whose voxels are
// all farther than forget_radius from the sensor (in the plane for 2-D tracks) — evidence the sensor
// can no longer refresh. With the default of matching() (max_range + 4 association distances) no
// voxel of this scan can reach a forgotten track (association reaches one distance, markStructure's
// neighbourhood at most 2 sqrt(3)), so the tracks kept are exactly those of a tracker that never
// forgets. Forgotten voxels leave the lookup structures lazily: they are skipped at once and the
// structures are rebuilt once they outnumber the live ones (memory at most about twice the live set).

#include <ddsnav/perception/obstacle.hpp>

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <vector>

namespace ddsnav::perception {

struct DetectorParams;

struct TrackerParams {
  double voxel_size = 0.1;            // m; 2-D evidence is de-duplicated on this grid (detector's voxel_size)
  // m; the grid of 3-D evidence. matching() gives twice the detector's voxel (at most association_distance):
  // a 3-D lidar sees surfaces, where a cell of twice the edge holds about four of the detector's voxels, so
  // a track keeps a quarter of the centroids to store, look up and refit, and every scan's new cells cost
  // a quarter as much (issue 16; docs/perception.md "3-D evidence grid"). The fit widens its quantisation
  // term and enclosing margin to this cell; the detector's finer voxels stay inside the tracks' ellipses but
  // for about one in a million (docs/benchmarks/perception.md).
  double voxel_size_3d = 0.1;
  double association_distance = 0.4;  // m; a voxel this close to a track's voxel is the same surface
  double max_segment_length = 1.5;    // m; a track's voxels stay inside a box of this side (> 0)...
  double max_segment_width = 0.25;    // m; ...and of this width along its thinnest axis (as the detector), 2-D
  double max_segment_width_3d = 0.4;  // m; the same in 3-D (as the detector)
  double segmentWidth(int dims) const { return dims == 3 ? max_segment_width_3d : max_segment_width; }
  double range_noise_sigma = 0.02;    // m; refit: sensor range noise
  bool enclose_points = true;         // refit: see EllipsoidFitParams::enclose_points
  std::size_t max_voxels_per_track = 100000;  // a further cap on one track's evidence
  // Updates a refresh-only change may wait for its refit (0: refit every changed track in the same
  // update, bit for bit the reference tracker). Only with enclose_points: a refreshed voxel outside
  // the current ellipse always refits at once.
  // 8 rather than 4: 6-8 % less tracker time on the city drives (docs/benchmarks/perception.md, 2026-12-02);
  // 16 gained nothing more.
  unsigned max_refit_delay = 8;
  std::size_t max_deferred_refits = 2000;  // per update, oldest first; the rest wait for the next one
  // m; update(detections, sensor_origin) forgets tracks with every voxel farther than this from the
  // sensor (infinity: keep everything; matching() gives max_range + 4 association distances).
  double forget_radius = std::numeric_limits<double>::infinity();

  double voxelSize(int dims) const { return dims == 3 ? voxel_size_3d : voxel_size; }

  // The tracker parameters that match a detector's (voxel size, tolerance, segment length, noise).
  static TrackerParams matching(const DetectorParams& detector);
  void validate() const;  // throws std::invalid_argument naming the bad parameter
};

struct TrackerUpdateStats {
  std::size_t fused = 0;         // detections that refreshed or extended at least one track
  std::size_t created = 0;       // new tracks
  std::size_t refreshed_voxels = 0;  // detection voxels in cells a track already owned
  std::size_t added_voxels = 0;      // detection voxels that extended a track
  std::size_t ignored = 0;       // detections without support points or with bad numbers
  std::size_t refitted = 0;      // tracks refitted in this update (grown, or a voxel left the ellipse)
  std::size_t refitted_late = 0; // ...of which refresh-only tracks whose refit had been deferred
  std::size_t deferred = 0;      // refresh-only tracks still showing an older (enclosing) ellipse
  std::size_t forgotten = 0;     // tracks dropped as entirely farther than forget_radius from the sensor
};

class ObstacleTracker {
 public:
  explicit ObstacleTracker(const TrackerParams& params = {});
  ~ObstacleTracker();
  ObstacleTracker(ObstacleTracker&&) noexcept;
  ObstacleTracker& operator=(ObstacleTracker&&) noexcept;

  // Forgets the tracks entirely farther than forget_radius from sensor_origin (the cloud's), then
  // associates one scan's detections (which must carry `support`, as ObstacleDetector's do);
  // returns all tracked obstacles (ids >= 1, in creation order, each with its voxels as `support`).
  const std::vector<ObstacleEllipsoid>& update(std::span<const ObstacleEllipsoid> detections,
                                               const Eigen::Vector3d& sensor_origin);
  // The same without a sensor origin: nothing is forgotten, the state grows with the world seen.
  const std::vector<ObstacleEllipsoid>& update(std::span<const ObstacleEllipsoid> detections);

  const std::vector<ObstacleEllipsoid>& obstacles() const { return tracks_; }

  // Marks as structure every track with evidence in or next to the association cell of one of `voxels` (the detector's
  // structure(): clusters too large to be an obstacle). A track started on a glimpse of a hill or a wall
  // becomes structure once a scan shows the whole of it. Structure tracks keep their evidence (nothing is
  // forgotten) but are no obstacles any more: discreteObstacles() leaves them out. Returns how many
  // tracks were newly marked.
  std::size_t markStructure(std::span<const Eigen::Vector3f> voxels, int dimensions);
  // Structure judged on the evidence of every scan, not one: a wall seen only at grazing angles (a doorway's
  // face beside the vehicle, the far part of a face) reaches the tracker as a string of short glimpses, none
  // long enough for the detector's structure_extent, and their ellipses closed a 1.6 m doorway for a 1 m robot.
  // Marks as structure every chain of tracks — tracks whose voxels lie in or next to each other's association
  // cells, the clustering's connectivity — that holds a track created, grown or refitted in the last update
  // and either spans more than `extent` (box diagonal, as the detector's structure_extent) or touches structure
  // (a structure track, or a cell where markStructure saw structure). Chains never run through structure
  // tracks. Returns how many tracks were newly marked; `extent` <= 0: none.
  std::size_t markStructureChains(double extent);
  bool isStructure(std::size_t index) const;
  // What perception publishes: indices into obstacles() of the tracks not marked as structure, in
  // creation order; when there are more than max_count, the max_count whose centres are nearest to
  // `from` (the sensor) — a hard bound on the published set however large the world grows.
  std::vector<std::size_t> discreteObstacles(const Eigen::Vector3d& from, std::size_t max_count) const;
  // Refits every track whose refit is deferred, so obstacles() is exactly the reference's now.
  const std::vector<ObstacleEllipsoid>& refitDeferred();
  // The current evidence of obstacles()[index] (its `support` is the evidence of its last refit).
  std::span<const SupportPoint> evidence(std::size_t index) const;
  const TrackerUpdateStats& lastUpdate() const { return last_; }
  const TrackerParams& params() const { return params_; }

 private:
  struct Evidence;
  const std::vector<ObstacleEllipsoid>& associate(std::span<const ObstacleEllipsoid> detections);
  void forget(const Eigen::Vector3d& sensor_origin);
  void absorb(const ObstacleEllipsoid& detection);
  void refit(std::size_t index);

  TrackerParams params_;
  std::vector<ObstacleEllipsoid> tracks_;
  std::unique_ptr<Evidence> evidence_;
  std::uint64_t next_id_ = 1;
  TrackerUpdateStats last_;
};

}  // namespace ddsnav::perception
