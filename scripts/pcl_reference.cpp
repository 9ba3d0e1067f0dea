// The reference of issue 4's speed requirement: what PCL 1.13 needs to read a cloud, build
// its k-d tree and estimate normals with curvature (NormalEstimationOMP, k nearest
// neighbours, N threads). Built and run by scripts/bench_vs_pcl.sh; not part of sharpedge.
//
// Usage: pcl_reference CLOUD.ply K THREADS
// Prints: read_s, normals_s (tree build + normal estimation), total_s, points.
#include <pcl/features/normal_3d_omp.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include <chrono>
#include <cstdlib>
#include <iostream>

int main(int argc, char** argv) {
    if (argc != 4) {
        std::cerr << "usage: pcl_reference CLOUD.ply K THREADS\n";
        return 2;
    }
    using clock = std::chrono::steady_clock;
    const auto t0 = clock::now();
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    if (pcl::io::loadPLYFile(argv[1], *cloud) < 0 || cloud->empty()) {
        std::cerr << argv[1] << ": PCL cannot read it\n";
        return 1;
    }
    const auto t1 = clock::now();
    pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> ne(std::atoi(argv[3]));
    ne.setInputCloud(cloud);
    ne.setSearchMethod(pcl::search::KdTree<pcl::PointXYZ>::Ptr(new pcl::search::KdTree<pcl::PointXYZ>));
    ne.setKSearch(std::atoi(argv[2]));
    pcl::PointCloud<pcl::Normal> normals;
    ne.compute(normals);
    const auto t2 = clock::now();
    const auto s = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
    std::cout << "read_s " << s(t0, t1) << " normals_s " << s(t1, t2) << " total_s " << s(t0, t2)
              << " points " << cloud->size() << "\n";
    return normals.size() == cloud->size() ? 0 : 1;
}
