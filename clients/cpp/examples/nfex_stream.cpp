// nfex_stream: a frame-to-frame loop over a KITTI-layout sequence folder (DIR/image_0/*.png) through
// one nFEX session. Per frame: ask the service (which sees the previous frame, so temporal metrics and
// motion work), build the extractor it chose, match against the previous frame with the norm it named,
// and print one JSON line with the choice. With --feedback NAME, each run of frames with one
// configuration is reported back (mean keypoints and matches) as a Measurement of sequence NAME.
//
//   nfex_stream --url http://127.0.0.1:8000 --context agent=car --sequence kitti/sequences/01 --limit 10
#include "cli.hpp"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <vector>

namespace {

struct Features {
    std::string config;  // the recipe that produced them: descriptors of two configurations don't match
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
};

Features extract(const nfex::Selection& s, const cv::Mat& grey) {
    Features f{s.raw["opencv"].dump(), {}, {}};
    nfex::make_feature2d(s)->detectAndCompute(grey, cv::noArray(), f.keypoints, f.descriptors);
    return f;
}

struct Window {  // consecutive frames run with one configuration
    nfex::Selection selection;
    int start = 0, end = 0;
    double keypoints = 0, matches = 0;
    int matched_frames = 0;
};

double ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
    const char* usage = "--url URL [--token T] [--context agent=car] --sequence DIR [--camera image_0] [--limit N] "
                        "[--feedback SEQUENCE_NAME] [--timeout S] [--retries N]";
    return cli::run("nfex_stream", usage, [&] {
        auto args = cli::parse(argc, argv, {"url", "token", "context", "sequence", "camera", "limit", "feedback", "timeout", "retries"});
        if (!args.count("url") || !args.count("sequence")) throw cli::Usage("--url and --sequence are required");
        namespace fs = std::filesystem;
        fs::path folder = fs::path(args["sequence"]) / (args.count("camera") ? args["camera"] : "image_0");
        if (!fs::is_directory(folder)) throw std::invalid_argument(folder.string() + " is not a folder (KITTI layout: DIR/image_0/*.png)");
        std::vector<fs::path> images;
        for (const auto& entry : fs::directory_iterator(folder))
            if (entry.path().extension() == ".png") images.push_back(entry.path());
        std::sort(images.begin(), images.end());
        if (args.count("limit")) images.resize(std::min<std::size_t>(images.size(), std::stoul(args["limit"])));
        if (images.empty()) throw std::invalid_argument("no .png frames in " + folder.string());

        nfex::Client nfex(args["url"], args.count("token") ? args["token"] : "", cli::options(args));
        nfex::Session session = nfex.open_session(nfex::parse_context(args.count("context") ? args["context"] : ""), "nfex_stream");
        cv::Mat previous;
        Features before;
        std::vector<Window> windows;
        for (std::size_t i = 0; i < images.size(); ++i) {
            cv::Mat grey = cv::imread(images[i].string(), cv::IMREAD_GRAYSCALE);
            if (grey.empty()) throw std::invalid_argument("cannot read " + images[i].string());
            auto t0 = std::chrono::steady_clock::now();
            nfex::Selection s = session.frame(grey);
            double service_ms = ms_since(t0);
            t0 = std::chrono::steady_clock::now();
            Features now = extract(s, grey);
            double extract_ms = ms_since(t0);
            nlohmann::json line = {{"frame", i}, {"image", images[i].filename().string()}, {"extractor", s.extractor},
                                   {"params", s.raw["params"]}, {"mode", s.mode}, {"temporal", s.session && s.session->temporal},
                                   {"keypoints", now.keypoints.size()}, {"service_ms", service_ms}, {"extract_ms", extract_ms}};
            if (windows.empty() || windows.back().selection.raw["opencv"].dump() != now.config)
                windows.push_back({s, int(i), int(i), 0, 0, 0});
            Window& w = windows.back();
            w.end = int(i) + 1;
            w.keypoints += double(now.keypoints.size());
            if (!previous.empty()) {  // the frame pair, with this frame's extractor on both
                if (before.config != now.config) before = extract(s, previous);
                std::vector<cv::DMatch> matches;
                if (!before.descriptors.empty() && !now.descriptors.empty())
                    nfex::make_matcher(s)->match(before.descriptors, now.descriptors, matches);
                line["matches"] = matches.size();
                w.matches += double(matches.size());
                w.matched_frames += 1;
            }
            std::cout << line.dump() << std::endl;
            previous = grey;
            before = std::move(now);
        }
        if (args.count("feedback")) {
            for (const Window& w : windows) {
                if (w.matched_frames == 0) continue;  // a result needs a frame pair
                nfex::Feedback fb = nfex::Feedback::of(w.selection);
                fb.sequence = args["feedback"];
                fb.client = "nfex_stream";
                fb.window_start = w.start;
                fb.window_end = w.end;
                fb.mean_keypoints = w.keypoints / (w.end - w.start);
                fb.mean_matches = w.matches / w.matched_frames;
                nfex::WriteResult r = session.feedback(fb);
                std::cout << nlohmann::json{{"feedback", r.iri.value_or("")}, {"version", r.version}, {"window", {w.start, w.end}}}.dump()
                          << std::endl;
            }
        }
        session.close();
        return 0;
    });
}
