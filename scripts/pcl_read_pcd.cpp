// The PCL reference of issue 16's PCD reading speed: PCL 1.13's pcl::io::loadPCDFile of a
// cloud into pcl::PointCloud<pcl::PointXYZRGB>. Built and run by scripts/bench_read_pcd.sh;
// not part of sharpedge.
//
// Usage: pcl_read_pcd CLOUD.pcd
// Prints: seconds points peak_rss_mb
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <chrono>
#include <fstream>
#include <iostream>
#include <string>

static double peak_rss_mb() {
    std::ifstream f("/proc/self/status");
    std::string line;
    while (std::getline(f, line)) {
        if (line.rfind("VmHWM:", 0) == 0) {
            return std::stod(line.substr(6)) / 1024.0;
        }
    }
    return -1.0;
}

int main(int argc, char** argv) {
    if (argc != 2) {
        std::cerr << "usage: pcl_read_pcd CLOUD.pcd\n";
        return 2;
    }
    const auto t0 = std::chrono::steady_clock::now();
    pcl::PointCloud<pcl::PointXYZRGB> cloud;
    if (pcl::io::loadPCDFile(argv[1], cloud) < 0 || cloud.empty()) {
        std::cerr << argv[1] << ": PCL cannot read it\n";
        return 1;
    }
    const auto t1 = std::chrono::steady_clock::now();
    std::cout << std::chrono::duration<double>(t1 - t0).count() << " " << cloud.size() << " "
              << peak_rss_mb() << "\n";
    return 0;
}
