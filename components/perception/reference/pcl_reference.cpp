// The only translation unit of ddsnav that includes PCL headers.
#include "ddsnav/perception/pcl_reference.hpp"

#include <pcl/common/centroid.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>

#include <Eigen/Eigenvalues>

namespace ddsnav::perception {

struct PclReferencePipeline::Impl {
  pcl::PointCloud<pcl::PointXYZ>::Ptr input{new pcl::PointCloud<pcl::PointXYZ>};
  pcl::PointCloud<pcl::PointXYZ>::Ptr downsampled{new pcl::PointCloud<pcl::PointXYZ>};
  pcl::PointCloud<pcl::PointXYZ>::Ptr objects{new pcl::PointCloud<pcl::PointXYZ>};
};

PclReferencePipeline::PclReferencePipeline(const DetectorParams& params)
    : params_(params), impl_(std::make_unique<Impl>()) {}
PclReferencePipeline::~PclReferencePipeline() = default;

void PclReferencePipeline::setInput(std::span<const Eigen::Vector3f> points) {
  auto& cloud = *impl_->input;
  cloud.clear();
  cloud.reserve(points.size());
  bool dense = true;
  for (const auto& p : points) {
    cloud.push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
    dense &= p.allFinite();
  }
  cloud.width = static_cast<std::uint32_t>(cloud.size());
  cloud.height = 1;
  cloud.is_dense = dense;  // VoxelGrid then skips the non-finite points itself
}

void PclReferencePipeline::run(int dimensions) {
  pcl::VoxelGrid<pcl::PointXYZ> grid;
  const float leaf = static_cast<float>(params_.voxel_size);
  grid.setLeafSize(leaf, leaf, leaf);
  grid.setInputCloud(impl_->input);
  grid.filter(*impl_->downsampled);
  voxels_before_ground_ = impl_->downsampled->size();

  auto& objects = *impl_->objects;
  objects.clear();
  const float ground = static_cast<float>(params_.ground_z);
  for (const auto& p : *impl_->downsampled)
    if (dimensions != 3 || !params_.remove_ground || p.z > ground) objects.push_back(p);
  objects.width = static_cast<std::uint32_t>(objects.size());
  objects.height = 1;

  std::vector<pcl::PointIndices> indices;
  if (!objects.empty()) {
    pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
    tree->setInputCloud(impl_->objects);
    pcl::EuclideanClusterExtraction<pcl::PointXYZ> extraction;
    extraction.setClusterTolerance(params_.cluster_tolerance);
    extraction.setMinClusterSize(static_cast<int>(std::min<std::size_t>(params_.min_cluster_size, INT32_MAX)));
    extraction.setMaxClusterSize(static_cast<int>(std::min<std::size_t>(params_.max_cluster_size, INT32_MAX)));
    extraction.setSearchMethod(tree);
    extraction.setInputCloud(impl_->objects);
    extraction.extract(indices);
  }

  voxels_.resize(objects.size());
  for (std::size_t i = 0; i < objects.size(); ++i) voxels_[i] = {objects[i].x, objects[i].y, objects[i].z};
  clusters_.clear();
  moments_.clear();
  for (const auto& cluster : indices) {
    clusters_.emplace_back(cluster.indices.begin(), cluster.indices.end());
    Eigen::Matrix3f covariance = Eigen::Matrix3f::Zero();
    Eigen::Vector4f centroid = Eigen::Vector4f::Zero();
    pcl::computeMeanAndCovarianceMatrix(objects, cluster.indices, covariance, centroid);
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> solver(covariance);
    moments_.push_back({centroid.head<3>().cast<double>(), covariance.cast<double>(),
                        solver.eigenvalues().cast<double>(), solver.eigenvectors().cast<double>()});
  }
}

}  // namespace ddsnav::perception
