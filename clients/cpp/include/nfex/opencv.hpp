// nFEX C++ client: the OpenCV side — build the extractor a selection names, its matcher, and encode
// frames for the wire.
//
// A selection's `opencv` recipe names the constructor by its cv2 path (the graph's
// nfex:opencvConstructor: "ORB_create", "SIFT_create", "xfeatures2d.AKAZE_create",
// "xfeatures2d.BRISK_create", "KAZE_create"…); the C++ factory is chosen by the last path segment,
// and the arguments are matched by OpenCV's own names. A recipe with a grid (ORB_GRID, ontology/grid.ttl)
// wraps the detector in GridSpread, which spreads the detected keypoints over square cells as the
// service's registry does (nfex_core/vision/registry.py, spread_over_grid).
#pragma once

#include "nfex/selection.hpp"

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include <string>
#include <vector>

namespace nfex {

/// cv::Ptr<cv::Feature2D> for α with Θ′. Throws ExtractorError for a constructor this client does not
/// know, an argument the constructor does not take, or one this OpenCV build cannot honour.
cv::Ptr<cv::Feature2D> make_feature2d(const OpenCVRecipe& recipe);
cv::Ptr<cv::Feature2D> make_feature2d(const Selection& selection);

/// cv::NORM_* for a norm name of the graph ("NORM_HAMMING", "NORM_HAMMING2", "NORM_L2", "NORM_L1").
int norm_type(const std::string& name);
/// A brute-force matcher with the norm the selection's descriptors need.
cv::Ptr<cv::DescriptorMatcher> make_matcher(const Selection& selection, bool cross_check = true);

/// Keeps `keep` keypoints (all when 0), round-robin over square cells of `cell` px by rank: every
/// cell's strongest keypoint (by response) before any cell's second; within a rank the stronger first;
/// ties in input order — the service's order exactly.
std::vector<cv::KeyPoint> spread_keypoints(const std::vector<cv::KeyPoint>& keypoints, int cell, int keep);

/// A Feature2D whose detections are spread over a grid (spread_keypoints) before the wrapped
/// detector computes their descriptors; ORB-SLAM's idea, as the graph's ORB_GRID describes it.
class GridSpread : public cv::Feature2D {
public:
    GridSpread(cv::Ptr<cv::Feature2D> detector, int cell_size, int keep);
    static cv::Ptr<GridSpread> create(cv::Ptr<cv::Feature2D> detector, int cell_size, int keep);

    void detectAndCompute(cv::InputArray image, cv::InputArray mask, std::vector<cv::KeyPoint>& keypoints,
                          cv::OutputArray descriptors, bool useProvidedKeypoints = false) override;
    int descriptorSize() const override { return detector_->descriptorSize(); }
    int descriptorType() const override { return detector_->descriptorType(); }
    int defaultNorm() const override { return detector_->defaultNorm(); }
    bool empty() const override { return detector_->empty(); }
    cv::String getDefaultName() const override { return "nfex.GridSpread"; }

    const cv::Ptr<cv::Feature2D>& detector() const { return detector_; }
    int cell_size() const { return cell_; }
    int keep() const { return keep_; }

private:
    cv::Ptr<cv::Feature2D> detector_;
    int cell_, keep_;
};

enum class FrameFormat { png, jpeg };

/// The frame encoded for the wire (PNG: lossless, 8 or 16 bit; JPEG: quality 95, 8 bit).
std::vector<unsigned char> encode_frame(const cv::Mat& frame, FrameFormat format = FrameFormat::png);

}  // namespace nfex
