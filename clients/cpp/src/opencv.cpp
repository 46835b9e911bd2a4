#include "nfex/opencv.hpp"

#include "nfex/errors.hpp"

#include <opencv2/core/version.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <set>
#include <stdexcept>
#include <utility>

namespace nfex {

namespace {

/// Reads a constructor's arguments by OpenCV name from Θ′, with OpenCV's default for a missing one;
/// done() refuses arguments nobody read (the constructor does not take them).
class Args {
public:
    Args(std::string constructor, const Params& params) : ctor_(std::move(constructor)), params_(params) {}

    int i(const std::string& name, int fallback) {
        const Value* v = find(name);
        if (v == nullptr) return fallback;
        double x = number(name, *v);
        if (x != std::floor(x) || x < std::numeric_limits<int>::min() || x > std::numeric_limits<int>::max())
            throw ExtractorError(ctor_ + ": " + name + " must be an integer, got " + std::to_string(x));
        return static_cast<int>(x);
    }

    double d(const std::string& name, double fallback) {
        const Value* v = find(name);
        return v == nullptr ? fallback : number(name, *v);
    }

    bool b(const std::string& name, bool fallback) {
        const Value* v = find(name);
        if (v == nullptr) return fallback;
        if (!std::holds_alternative<bool>(*v)) throw ExtractorError(ctor_ + ": " + name + " must be a boolean");
        return std::get<bool>(*v);
    }

    void done() const {
        for (const auto& [name, v] : params_)
            if (read_.count(name) == 0) {
                std::string takes;
                for (const auto& r : read_) takes += (takes.empty() ? "" : ", ") + r;
                throw ExtractorError(ctor_ + " takes no argument '" + name + "'; it takes: " + takes);
            }
    }

private:
    const Value* find(const std::string& name) {
        read_.insert(name);
        auto it = params_.find(name);
        return it == params_.end() ? nullptr : &it->second;
    }

    double number(const std::string& name, const Value& v) const {
        if (std::holds_alternative<bool>(v)) throw ExtractorError(ctor_ + ": " + name + " must be a number, got a boolean");
        return to_double(v);
    }

    std::string ctor_;
    const Params& params_;
    std::set<std::string> read_;
};

cv::Ptr<cv::Feature2D> orb(Args& a) {
    return cv::ORB::create(a.i("nfeatures", 500), static_cast<float>(a.d("scaleFactor", 1.2)), a.i("nlevels", 8),
                           a.i("edgeThreshold", 31), a.i("firstLevel", 0), a.i("WTA_K", 2),
                           static_cast<cv::ORB::ScoreType>(a.i("scoreType", cv::ORB::HARRIS_SCORE)), a.i("patchSize", 31),
                           a.i("fastThreshold", 20));
}

cv::Ptr<cv::Feature2D> sift(Args& a) {
    int nfeatures = a.i("nfeatures", 0), layers = a.i("nOctaveLayers", 3);
    double contrast = a.d("contrastThreshold", 0.04), edge = a.d("edgeThreshold", 10.0), sigma = a.d("sigma", 1.6);
    bool precise = a.b("enable_precise_upscale", false);
#if CV_VERSION_MAJOR > 4 || (CV_VERSION_MAJOR == 4 && CV_VERSION_MINOR >= 8)
    return cv::SIFT::create(nfeatures, layers, contrast, edge, sigma, precise);
#else
    if (precise) throw ExtractorError("SIFT enable_precise_upscale=true needs OpenCV 4.8 or later; this is " CV_VERSION);
    return cv::SIFT::create(nfeatures, layers, contrast, edge, sigma);
#endif
}

cv::Ptr<cv::Feature2D> akaze(Args& a) {
    auto type = static_cast<cv::AKAZE::DescriptorType>(a.i("descriptor_type", cv::AKAZE::DESCRIPTOR_MLDB));
    int size = a.i("descriptor_size", 0), channels = a.i("descriptor_channels", 3);
    auto threshold = static_cast<float>(a.d("threshold", 0.001));
    int octaves = a.i("nOctaves", 4), layers = a.i("nOctaveLayers", 4);
    auto diffusivity = static_cast<cv::KAZE::DiffusivityType>(a.i("diffusivity", cv::KAZE::DIFF_PM_G2));
    if (a.i("max_points", -1) != -1)  // OpenCV's newer AKAZE_create takes it; this client passes only "no limit"
        throw ExtractorError("AKAZE max_points other than -1 is not supported by this client (OpenCV " CV_VERSION ")");
    return cv::AKAZE::create(type, size, channels, threshold, octaves, layers, diffusivity);
}

cv::Ptr<cv::Feature2D> brisk(Args& a) {
    return cv::BRISK::create(a.i("thresh", 30), a.i("octaves", 3), static_cast<float>(a.d("patternScale", 1.0)));
}

cv::Ptr<cv::Feature2D> kaze(Args& a) {
    return cv::KAZE::create(a.b("extended", false), a.b("upright", false), static_cast<float>(a.d("threshold", 0.001)),
                            a.i("nOctaves", 4), a.i("nOctaveLayers", 4),
                            static_cast<cv::KAZE::DiffusivityType>(a.i("diffusivity", cv::KAZE::DIFF_PM_G2)));
}

}  // namespace

cv::Ptr<cv::Feature2D> make_feature2d(const OpenCVRecipe& recipe) {
    const std::string& path = recipe.constructor;
    std::string name = path.substr(path.rfind('.') == std::string::npos ? 0 : path.rfind('.') + 1);
    using Factory = cv::Ptr<cv::Feature2D> (*)(Args&);
    static const std::pair<const char*, Factory> factories[] = {
        {"ORB_create", orb}, {"SIFT_create", sift}, {"AKAZE_create", akaze}, {"BRISK_create", brisk}, {"KAZE_create", kaze}};
    for (const auto& [known, factory] : factories) {
        if (name != known) continue;
        Args args(path, recipe.args);
        cv::Ptr<cv::Feature2D> detector = factory(args);
        args.done();
        if (recipe.grid) return GridSpread::create(detector, recipe.grid->cell_size, recipe.grid->keep);
        return detector;
    }
    throw ExtractorError("this client cannot build the OpenCV constructor '" + path +
                         "'; it builds ORB_create, SIFT_create, AKAZE_create, BRISK_create and KAZE_create");
}

cv::Ptr<cv::Feature2D> make_feature2d(const Selection& selection) { return make_feature2d(selection.opencv); }

int norm_type(const std::string& name) {
    static const std::pair<const char*, int> norms[] = {{"NORM_HAMMING", cv::NORM_HAMMING}, {"NORM_HAMMING2", cv::NORM_HAMMING2},
                                                        {"NORM_L2", cv::NORM_L2}, {"NORM_L1", cv::NORM_L1},
                                                        {"NORM_L2SQR", cv::NORM_L2SQR}, {"NORM_INF", cv::NORM_INF}};
    for (const auto& [known, norm] : norms)
        if (name == known) return norm;
    throw ExtractorError("unknown matching norm '" + name + "'");
}

cv::Ptr<cv::DescriptorMatcher> make_matcher(const Selection& selection, bool cross_check) {
    return cv::BFMatcher::create(norm_type(selection.opencv.norm), cross_check);
}

std::vector<cv::KeyPoint> spread_keypoints(const std::vector<cv::KeyPoint>& keypoints, int cell, int keep) {
    if (cell <= 0) throw std::invalid_argument("the grid cell size must be positive");
    const std::size_t n = keypoints.size();
    if (n == 0) return {};
    std::vector<std::int64_t> cx(n), cell_id(n);
    for (std::size_t i = 0; i < n; ++i) cx[i] = static_cast<std::int64_t>(std::floor(double(keypoints[i].pt.x) / cell));
    const std::int64_t width = *std::max_element(cx.begin(), cx.end()) + 1;
    for (std::size_t i = 0; i < n; ++i)
        cell_id[i] = static_cast<std::int64_t>(std::floor(double(keypoints[i].pt.y) / cell)) * width + cx[i];
    auto stronger = [&](std::size_t a, std::size_t b) { return keypoints[a].response > keypoints[b].response; };

    std::vector<std::size_t> order(n);  // by cell, the strongest first within a cell
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        return cell_id[a] != cell_id[b] ? cell_id[a] < cell_id[b] : stronger(a, b);
    });
    std::vector<std::size_t> rank(n);  // 0 for each cell's strongest, 1 for its second…
    for (std::size_t pos = 0; pos < n; ++pos)
        rank[order[pos]] = pos > 0 && cell_id[order[pos - 1]] == cell_id[order[pos]] ? rank[order[pos - 1]] + 1 : 0;

    std::vector<std::size_t> chosen(n);
    std::iota(chosen.begin(), chosen.end(), 0);
    std::stable_sort(chosen.begin(), chosen.end(),
                     [&](std::size_t a, std::size_t b) { return rank[a] != rank[b] ? rank[a] < rank[b] : stronger(a, b); });
    if (keep > 0 && static_cast<std::size_t>(keep) < n) chosen.resize(static_cast<std::size_t>(keep));
    std::vector<cv::KeyPoint> out;
    out.reserve(chosen.size());
    for (std::size_t i : chosen) out.push_back(keypoints[i]);
    return out;
}

GridSpread::GridSpread(cv::Ptr<cv::Feature2D> detector, int cell_size, int keep)
    : detector_(std::move(detector)), cell_(cell_size), keep_(keep) {
    if (!detector_) throw std::invalid_argument("GridSpread needs a detector");
    if (cell_ <= 0) throw std::invalid_argument("the grid cell size must be positive");
}

cv::Ptr<GridSpread> GridSpread::create(cv::Ptr<cv::Feature2D> detector, int cell_size, int keep) {
    return cv::makePtr<GridSpread>(std::move(detector), cell_size, keep);
}

void GridSpread::detectAndCompute(cv::InputArray image, cv::InputArray mask, std::vector<cv::KeyPoint>& keypoints,
                                  cv::OutputArray descriptors, bool useProvidedKeypoints) {
    if (!useProvidedKeypoints) {
        std::vector<cv::KeyPoint> found;
        detector_->detect(image, found, mask);
        keypoints = spread_keypoints(found, cell_, keep_);
    }
    if (descriptors.needed()) detector_->compute(image, keypoints, descriptors);
}

std::vector<unsigned char> encode_frame(const cv::Mat& frame, FrameFormat format) {
    if (frame.empty()) throw std::invalid_argument("the frame is empty");
    std::vector<unsigned char> out;
    bool ok = format == FrameFormat::png
                  ? cv::imencode(".png", frame, out)
                  : cv::imencode(".jpg", frame, out, {cv::IMWRITE_JPEG_QUALITY, 95});
    if (!ok) throw std::invalid_argument("OpenCV could not encode the frame");
    return out;
}

}  // namespace nfex
