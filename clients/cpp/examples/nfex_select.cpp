// nfex_select: ask a running nFEX service which extractor to run on one frame, build it with OpenCV
// C++ and count its keypoints on that frame. Prints one JSON object: the selection plus "keypoints".
//
//   nfex_select --url http://127.0.0.1:8000 --context agent=car,scene=outdoor --frame 000000.png
#include "cli.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

int main(int argc, char** argv) {
    const char* usage = "--url URL [--token T] [--context agent=car,scene=outdoor] --frame FILE [--timeout S] [--retries N]";
    return cli::run("nfex_select", usage, [&] {
        auto args = cli::parse(argc, argv, {"url", "token", "context", "frame", "timeout", "retries"});
        if (!args.count("url") || !args.count("frame")) throw cli::Usage("--url and --frame are required");
        cv::Mat frame = cv::imread(args["frame"], cv::IMREAD_UNCHANGED);
        if (frame.empty()) throw std::invalid_argument("cannot read the frame " + args["frame"]);

        nfex::Client nfex(args["url"], args.count("token") ? args["token"] : "", cli::options(args));
        nfex::Selection selection = nfex.select(frame, nfex::parse_context(args.count("context") ? args["context"] : ""));

        cv::Mat grey = frame;
        if (frame.channels() > 1) cv::cvtColor(frame, grey, frame.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
        if (grey.depth() != CV_8U) grey.convertTo(grey, CV_8U, 255.0 / 65535.0);
        std::vector<cv::KeyPoint> keypoints;
        cv::Mat descriptors;
        nfex::make_feature2d(selection)->detectAndCompute(grey, cv::noArray(), keypoints, descriptors);

        nlohmann::json out = selection.raw;
        out["keypoints"] = keypoints.size();
        std::cout << out.dump(2) << "\n";
        return 0;
    });
}
