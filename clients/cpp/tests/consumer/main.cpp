#include <nfex/nfex.hpp>

#include <iostream>

int main() {
    nfex::Context context = nfex::parse_context("agent=car");
    auto orb = nfex::make_feature2d(nfex::OpenCVRecipe{"ORB_create", "NORM_HAMMING", {}, std::nullopt});
    std::cout << context.at("agent") << " " << orb->getDefaultName() << "\n";
    return orb ? 0 : 1;
}
